// The offline program's story: a scene's .prm becomes validated modal spaces and their exports.
//
//   make_meshes()                 gmsh: one graded mesh per scenario + the display surface
//   plan_contacts()               which display vertices get a static correction and a validation
//   compute_modal_space()         per space: assemble, eigensolve, select, correct, validate
//   compute_transfer_matrices()   the state carried across a switch between spaces
//   export_results()              .h5, .mrt, report.json, used_parameters.prm
#pragma once

#include "display_surface.h"
#include "modal_space.h"
#include "scene_parameters.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>

#include <string>
#include <vector>

namespace modal_haptics
{
  // T_(to <- from): q_to = T q_from, r_to x r_from row-major.
  struct TransferMatrix
  {
    unsigned int        to = 0, from = 0;
    unsigned int        rows = 0, columns = 0;
    std::vector<double> values;
    double              relative_residual = 0.; // area-weighted LS residual of carrying the modes of 'from'
  };

  // Everything the exporters write; filled by ModalPrecompute::run().
  struct PrecomputeResults
  {
    meshing::SceneMeshes          meshes;
    DisplaySurface                display;
    std::vector<SpaceTask>        tasks;
    std::vector<ModalSpaceResult> spaces;
    std::vector<TransferMatrix>   transfers;
    std::map<std::string, double> timings_s;
    unsigned int                  n_processes = 1;           // MPI processes that computed the spaces
    double                        max_peak_memory_mb = 0.;   // largest peak resident memory of one process
  };

  class StagedFiles; // atomic_file.h

  // With 'distributed', every process of MPI_COMM_WORLD runs run(): the spaces are computed on
  // distributed objects (distributed_space.h), process 0 meshes first and writes every file.
  //
  // A scene can also be computed as separate jobs (docs/cluster.md): mesh_only() makes the meshes
  // once, run_scenario() computes one scenario's space from them into a partial result
  // (partial_result.h), merge() checks the partial results of every scenario and writes the files
  // run() would write.
  class ModalPrecompute
  {
  public:
    ModalPrecompute(const SceneParameters &scene, const dealii::ParameterHandler &prm, bool verbose = true,
                    bool distributed = false);
    void run();
    void mesh_only();
    void run_scenario(const std::string &name, const std::string &partial_directory);
    void merge(const std::string &partial_directory);
    const PrecomputeResults &get_results() const { return results; }

  private:
    void create_output_directory() const;
    void make_meshes(bool reuse_only = false);
    void plan_contacts(const std::string &vtu_directory);
    const SpaceTask &task_of_scenario(const std::string &name) const;
    void compute_modal_space(const SpaceTask &task);
    void record_peak_memory();
    void read_partial_results(const std::string &partial_directory, double &job_seconds);
    void write_results(double earlier_seconds);
    void compute_transfer_matrices();
    void export_results(StagedFiles &staged);
    std::string parameters_text() const;

    const SceneParameters          &scene;
    const dealii::ParameterHandler &prm;
    const bool                      verbose;
    const bool                      distributed;
    const bool                      writes_files; // the serial run, or process 0 of a distributed one
    dealii::TimerOutput             timer;
    PrecomputeResults               results;
  };

  // T_(k <- j) for every ordered pair of spaces: least squares over the display surface.
  std::vector<TransferMatrix> compute_transfer_matrices(const DisplaySurface &display,
                                                        const std::vector<ModalSpaceResult> &spaces);

  // The display vertex nearest to a point given in geometry units.
  unsigned int nearest_display_vertex(const DisplaySurface &display, const meshing::Point3 &point, double length_unit);

  // The exporters (export_results.cc). Each stages its file in `staged` (atomic_file.h): written
  // complete to a temporary file, renamed over `filename` when the run commits its results.
  void write_hdf5_file(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                       StagedFiles &staged);
  // The same file written by every process of 'comm' together with parallel HDF5: each writes its
  // own rows of the per-vertex and per-tet datasets, process 0 the rest and stages the file ('staged'
  // is used on process 0 only).
  void write_hdf5_file_parallel(const std::string &filename, const SceneParameters &scene,
                                const PrecomputeResults &results, StagedFiles *staged, MPI_Comm comm);
  void write_basis_file(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                        StagedFiles &staged);
  void write_report(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                    StagedFiles &staged);
} // namespace modal_haptics
