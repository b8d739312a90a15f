// The offline program's story: a scene's .prm becomes validated modal spaces and their exports.
//
//   make_meshes()                 gmsh: one graded mesh per scenario + the display surface
//   plan_contacts()               which display vertices get a static correction and a validation
//   solve_space()                 per space (compute_modal_space, modal_space.h): assemble,
//                                 eigensolve, select, correct, validate; its VTU where the caller says
//   add_transfer_matrices()       the state carried across a switch between spaces
//   export_results()              .h5, .mrt, report.json, used_parameters.prm (exporters.h)
//
// Data flows one way: parameters -> meshes and display surface -> space tasks (what to compute,
// no output paths) -> space results -> the scene's files.
#pragma once

#include "scene/display_surface.h"
#include "output/exporters.h"
#include "results/space_result.h"
#include "parameters/scene_parameters.h"
#include "parameters/variant_parameters.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>

#include <string>
#include <vector>

namespace modal_haptics
{
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
    void run(); // compute(), then write()
    // The meshes and every space; nothing written but the meshes and the spaces' VTU files.
    void compute();
    // The scene's files (.h5, .mrt, report.json, ...), renamed into place together.
    void write();
    // Meshes of 'folder' made from this scene's meshing inputs are taken instead of meshing again
    // (a design variant of the material takes its base's: the same display surface).
    void take_meshes_from(const std::string &folder) { shared_mesh_folder = folder; }
    void set_design_record(DesignRecord record) { results.design = std::move(record); }
    void mesh_only();
    void run_scenario(const std::string &name, const std::string &partial_directory);
    void merge(const std::string &partial_directory);
    const PrecomputeResults &get_results() const { return results; }

  private:
    void create_output_directory() const;
    void make_meshes(bool reuse_only = false);
    void plan_contacts();
    std::vector<unsigned int> candidates_of_space(unsigned int space) const; // before thinning
    const SpaceTask &task_of_scenario(const std::string &name) const;
    // The space of 'task', its VTU written into vtu_directory.
    void solve_space(const SpaceTask &task, const std::string &vtu_directory);
    void wait_for_vtu_files();
    void record_peak_memory();
    void read_partial_results(const std::string &partial_directory, double &job_seconds);
    // The scene's files; a merge also gathers the VTU files its jobs wrote in jobs_directory.
    void write_results(double earlier_seconds, const std::string &jobs_directory = "");
    void add_transfer_matrices();
    void export_results(StagedFiles &staged);
    std::string parameters_text() const;

    const SceneParameters          &scene;
    const dealii::ParameterHandler &prm;
    const bool                      verbose;
    const bool                      distributed;
    const bool                      writes_files; // the serial run, or process 0 of a distributed one
    dealii::TimerOutput             timer;
    PrecomputeResults               results;
    std::string                     shared_mesh_folder;
    double                          compute_seconds = 0.;
  };

  // The scene's felt-stiffness map: each display vertex's value from the space whose region holds it.
  FeltStiffnessMap felt_stiffness_map(const PrecomputeResults &results);

  // A scene with design variants ('Variants', parameters/variant_parameters.h): the base design into
  // the scene's folder, each variant into <folder>/variants/<name>/ (the base's meshes where its
  // meshing inputs are the base's), the noise floor's run (when 'noise_floor' holds it) into
  // <folder>/noise_floor/, each a whole precompute with its own files; the base's report.json, written
  // last, compares every variant's felt-stiffness map with the base's.
  void run_with_variants(const SceneParameters &base, const dealii::ParameterHandler &prm,
                         const std::vector<VariantScene> &variants, const VariantScene *noise_floor,
                         double noise_floor_mesh_scale, bool verbose, bool distributed);

  // T_(k <- j) for every ordered pair of spaces: least squares over the display surface.
  std::vector<TransferMatrix> compute_transfer_matrices(const ContactSurface &display,
                                                        const std::vector<ModalSpaceResult> &spaces);

  // The display vertex nearest to a point given in geometry units.
  unsigned int nearest_display_vertex(const ContactSurface &display, const meshing::Point3 &point, double length_unit);

} // namespace modal_haptics
