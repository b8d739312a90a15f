// What a scene's run computed, and the exporters that write it (export_results.cc): the .h5
// (hdf5-layout.md), the .mrt (the kernel's basis file) and report.json (report-schema.md).
#pragma once

#include "parameters/scene_parameters.h"
#include "scene/display_surface.h"
#include "results/design_comparison.h"
#include "results/space_result.h"

#include <deal.II/base/mpi.h>

#include <map>
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
    ContactSurface                display;
    std::vector<SpaceTask>        tasks;
    std::vector<ModalSpaceResult> spaces;
    std::vector<TransferMatrix>   transfers;
    std::map<std::string, double> timings_s;
    unsigned int                  n_processes = 1;           // MPI processes that computed the spaces
    double                        max_peak_memory_mb = 0.;   // largest peak resident memory of one process
    DesignRecord                  design; // design variants: the base's comparisons, or a variant's name
  };

  class StagedFiles; // atomic_file.h

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
  // The felt-stiffness map on the display surface for ParaView: per space, the felt and the modal-only
  // normal stiffness [N/mm] at every display vertex, and each vertex's region (the space whose VOI holds it).
  void write_felt_stiffness_vtu(const std::string &filename, const PrecomputeResults &results, StagedFiles &staged);
  // The validity map on the display surface for ParaView, when some space has one: per space, the
  // 1, 5 and 10 % validity forces [N] at every display vertex (0: no value, -1: not reached).
  void write_validity_vtu(const std::string &filename, const PrecomputeResults &results, StagedFiles &staged);
  void write_report(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                    StagedFiles &staged);
} // namespace modal_haptics
