#include "modal_precompute.h"

#include "atomic_file.h"
#include "distributed_space.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>
#include <deal.II/lac/full_matrix.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using dealii::TimerOutput;

  ModalPrecompute::ModalPrecompute(const SceneParameters &scene, const dealii::ParameterHandler &prm,
                                   const bool verbose, const bool distributed)
    : scene(scene)
    , prm(prm)
    , verbose(verbose)
    , distributed(distributed)
    , writes_files(!distributed || dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD) == 0)
    , timer(std::cout, verbose ? TimerOutput::summary : TimerOutput::never, TimerOutput::wall_times)
  {}

  void ModalPrecompute::run()
  {
    dealii::Timer total;
    if (writes_files)
      {
        std::error_code error;
        std::filesystem::create_directories(scene.output_directory, error);
        AssertThrow(!error && std::filesystem::is_directory(scene.output_directory),
                    ExcMessage("Cannot create the output folder '" + scene.output_directory + "': " + error.message()));
      }

    make_meshes();
    plan_contacts();
    compute_modal_spaces();
    record_peak_memory();
    // Every process holds what the parallel .h5 needs (its own rows of the per-vertex data, and the
    // rest in full); process 0 alone writes the other files.
    compute_transfer_matrices();
    StagedFiles staged;
    export_results(staged);
    if (!writes_files)
      return;
    // The report is written last: it gives the size of every other file and the total time.
    results.timings_s["total"] = total.wall_time();
    write_report(scene.output_directory + "/report.json", scene, results, staged);
    staged.commit();
  }

  void ModalPrecompute::make_meshes()
  {
    TimerOutput::Scope scope(timer, "meshing");
    dealii::Timer      wall;
    try
      {
        // Process 0 meshes (or finds the cached meshes); then the others read the same files from
        // the cache, so that gmsh never writes one file from two processes. A failure on process 0
        // aborts the run (main), so the barrier cannot hang.
        if (writes_files)
          results.meshes = meshing::mesh_scene(scene.meshing, scene.volumes_of_interest, scene.output_directory, verbose);
        if (distributed)
          MPI_Barrier(MPI_COMM_WORLD);
        if (!writes_files)
          results.meshes = meshing::mesh_scene(scene.meshing, scene.volumes_of_interest, scene.output_directory, false);
      }
    catch (const meshing::MeshingError &e)
      {
        AssertThrow(false, ExcMessage(std::string("Meshing failed: ") + e.what()));
      }
    results.display = make_display_surface(results.meshes.display_surface, scene.volumes_of_interest,
                                           scene.length_unit, scene.contact.patch_radius * scene.length_unit);
    results.timings_s["meshing"] = wall.wall_time();
    if (verbose)
      std::cout << "[display] " << results.display.n_vertices() << " vertices, " << results.display.triangles.size()
                << " triangles, contact patches of up to " << results.display.max_patch_size << " vertices" << std::endl;
  }

  namespace
  {
    // Every k-th entry so that at most 'maximum' remain, spread over the whole list.
    std::vector<unsigned int> thin_evenly(const std::vector<unsigned int> &list, const unsigned int maximum)
    {
      if (list.size() <= maximum)
        return list;
      std::vector<unsigned int> thinned;
      for (unsigned int k = 0; k < maximum; ++k)
        thinned.push_back(list[(std::size_t(k) * list.size()) / maximum]);
      return thinned;
    }

  } // namespace

  unsigned int nearest_display_vertex(const DisplaySurface &display, const meshing::Point3 &point,
                                      const double length_unit)
  {
    unsigned int best = 0;
    double       best_distance = 1e300;
    for (unsigned int v = 0; v < display.n_vertices(); ++v)
      {
        double d = 0.;
        for (unsigned int c = 0; c < 3; ++c)
          d += std::pow(display.vertices[v][c] - point[c] * length_unit, 2);
        if (d < best_distance)
          best_distance = d, best = v;
      }
    return best;
  }

  // A VOI space's candidates are the display vertices inside its VOI; the global space's are every
  // n-th vertex outside all VOIs (none by default): "model only what a scene requires".
  void ModalPrecompute::plan_contacts()
  {
    const auto &display = results.display;
    std::vector<unsigned int> shared;
    for (unsigned int s = 0; s < results.meshes.scenarios.size(); ++s)
      {
        const auto &mesh = results.meshes.scenarios[s];
        SpaceTask   task;
        task.name              = mesh.name;
        task.index             = s;
        task.msh_file          = mesh.msh_file;
        task.physical_surfaces = mesh.physical_surfaces;
        task.vtu_file          = scene.output_directory + "/modes_" + mesh.name + ".vtu";
        std::vector<unsigned int> in_region;
        unsigned int              seen = 0;
        for (unsigned int v = 0; v < display.n_vertices(); ++v)
          if (display.region[v] == s)
            {
              if (s > 0 || (scene.contact.global_candidate_stride > 0 && seen % scene.contact.global_candidate_stride == 0))
                in_region.push_back(v);
              ++seen;
            }
        task.candidates          = thin_evenly(in_region, scene.contact.maximum_candidates);
        task.validation_vertices = thin_evenly(task.candidates, scene.contact.validation_samples);
        shared.insert(shared.end(), task.validation_vertices.begin(), task.validation_vertices.end());
        if (verbose)
          std::cout << "[contacts] space '" << task.name << "': " << task.candidates.size() << " candidates, "
                    << task.validation_vertices.size() << " validated" << std::endl;
        results.tasks.push_back(task);
      }
    for (const auto &point : scene.contact.validation_points)
      {
        const unsigned int v = nearest_display_vertex(display, point, scene.length_unit);
        auto &task = results.tasks[display.region[v]];
        for (auto *list : {&task.candidates, &task.validation_vertices})
          if (std::find(list->begin(), list->end(), v) == list->end())
            {
              list->push_back(v);
              std::sort(list->begin(), list->end());
            }
        shared.push_back(v);
        if (verbose)
          std::cout << "[contacts] validation point (" << point[0] << ", " << point[1] << ", " << point[2]
                    << ") -> display vertex " << v << " in space '" << task.name << "'" << std::endl;
      }
    std::sort(shared.begin(), shared.end());
    shared.erase(std::unique(shared.begin(), shared.end()), shared.end());
    for (auto &task : results.tasks)
      task.shared_vertices = shared;
  }

  void ModalPrecompute::compute_modal_spaces()
  {
    for (const auto &task : results.tasks)
      {
        if (verbose)
          std::cout << "[space " << task.index + 1 << "/" << results.tasks.size() << "] " << task.name << std::endl;
        ModalSpaceResult space =
          distributed ? compute_modal_space_distributed(scene, results.display, task, timer, verbose, MPI_COMM_WORLD) :
                        compute_modal_space(scene, results.display, task, timer, verbose);
        for (const auto &[phase, seconds] : space.timings_s)
          results.timings_s[phase] += seconds;
        results.spaces.push_back(std::move(space));
      }
  }

  // The peak resident memory (VmHWM) of the largest process: what a cluster node must hold per process.
  void ModalPrecompute::record_peak_memory()
  {
    dealii::Utilities::System::MemoryStats memory;
    dealii::Utilities::System::get_memory_stats(memory);
    results.max_peak_memory_mb = memory.VmHWM / 1024.;
    if (distributed)
      {
        results.n_processes        = dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD);
        results.max_peak_memory_mb = dealii::Utilities::MPI::max(results.max_peak_memory_mb, MPI_COMM_WORLD);
      }
  }

  // T_(k <- j) = argmin_T || Phi_k T - Phi_j ||_A over the display surface, with A the lumped vertex
  // areas: the normal equations (Phi_k^T A Phi_k) T = Phi_k^T A Phi_j, small and dense.
  std::vector<TransferMatrix> compute_transfer_matrices(const DisplaySurface &display,
                                                        const std::vector<ModalSpaceResult> &spaces)
  {
    std::vector<TransferMatrix> transfers;
    const unsigned int          nv = display.n_vertices();
    for (const auto &to : spaces)
      for (const auto &from : spaces)
        {
          if (to.index == from.index)
            continue;
          const unsigned int rk = to.eigenvalues.size(), rj = from.eigenvalues.size();
          dealii::FullMatrix<double> G(rk, rk), R(rk, rj);
          for (unsigned int row = 0; row < 3 * nv; ++row)
            {
              const double  area = display.vertex_area[row / 3];
              const double *pk   = &to.display_modes[std::size_t(row) * rk];
              const double *pj   = &from.display_modes[std::size_t(row) * rj];
              for (unsigned int a = 0; a < rk; ++a)
                {
                  for (unsigned int b = 0; b < rk; ++b)
                    G(a, b) += area * pk[a] * pk[b];
                  for (unsigned int b = 0; b < rj; ++b)
                    R(a, b) += area * pk[a] * pj[b];
                }
            }
          G.gauss_jordan();
          dealii::FullMatrix<double> T(rk, rj);
          G.mmult(T, R);

          TransferMatrix transfer;
          transfer.to      = to.index;
          transfer.from    = from.index;
          transfer.rows    = rk;
          transfer.columns = rj;
          for (unsigned int a = 0; a < rk; ++a)
            for (unsigned int b = 0; b < rj; ++b)
              transfer.values.push_back(T(a, b));
          // How well the modes of 'from' are represented in 'to': area-weighted relative residual.
          double residual = 0., norm = 0.;
          for (unsigned int row = 0; row < 3 * nv; ++row)
            {
              const double area = display.vertex_area[row / 3];
              for (unsigned int b = 0; b < rj; ++b)
                {
                  double carried = 0.;
                  for (unsigned int a = 0; a < rk; ++a)
                    carried += to.display_modes[std::size_t(row) * rk + a] * T(a, b);
                  const double original = from.display_modes[std::size_t(row) * rj + b];
                  residual += area * (carried - original) * (carried - original);
                  norm += area * original * original;
                }
            }
          transfer.relative_residual = std::sqrt(residual / norm);
          transfers.push_back(std::move(transfer));
        }
    return transfers;
  }

  void ModalPrecompute::compute_transfer_matrices()
  {
    TimerOutput::Scope scope(timer, "transfer matrices");
    results.transfers = modal_haptics::compute_transfer_matrices(results.display, results.spaces);
  }

  void ModalPrecompute::export_results(StagedFiles &staged)
  {
    TimerOutput::Scope scope(timer, "export");
    dealii::Timer      wall;
    const std::string  base = scene.output_directory + "/" + scene.scene_name;
    if (distributed)
      write_hdf5_file_parallel(base + ".h5", scene, results, &staged, MPI_COMM_WORLD);
    else
      write_hdf5_file(base + ".h5", scene, results, staged);
    if (!writes_files)
      return;
    write_basis_file(base + ".mrt", scene, results, staged);
    staged.write(scene.output_directory + "/used_parameters.prm",
                 [&](std::ostream &out) { prm.print_parameters(out, dealii::ParameterHandler::Text); });
    for (const auto &task : results.tasks)
      staged.write(scene.output_directory + "/modes_" + task.name + ".pvd", [&](std::ostream &out) {
        out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n"
            << "    <DataSet timestep=\"0\" group=\"\" part=\"0\" file=\"modes_" << task.name << ".vtu\"/>\n"
            << "  </Collection>\n</VTKFile>\n";
      });
    results.timings_s["export"] = wall.wall_time();
  }
} // namespace modal_haptics
