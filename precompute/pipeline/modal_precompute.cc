#include "pipeline/modal_precompute.h"

#include "output/atomic_file.h"
#include "pipeline/design_comparison.h"
#include "shared_meshes.h"
#include "space/distributed_space.h"
#include "space/modal_space.h"
#include "output/partial_result.h"
#include "solvers/mpi_launcher.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>
#include <deal.II/lac/full_matrix.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
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

  namespace
  {
    // Where a space's mode shapes go: DIRECTORY/modes_SPACE.vtu (the output folder, or a scenario
    // job's partial results folder).
    std::string vtu_file(const std::string &directory, const std::string &space)
    {
      return directory + "/modes_" + space + ".vtu";
    }

    // 'what' names the folder in the message: "output folder", "partial results folder".
    void create_folder(const std::string &folder, const std::string &what)
    {
      std::error_code error;
      std::filesystem::create_directories(folder, error);
      AssertThrow(!error && std::filesystem::is_directory(folder),
                  ExcMessage("Cannot create the " + what + " '" + folder + "': " + error.message()));
    }
  } // namespace

  void ModalPrecompute::create_output_directory() const
  {
    if (writes_files)
      create_folder(scene.output_directory, "output folder");
  }

  void ModalPrecompute::run()
  {
    compute();
    write();
  }

  void ModalPrecompute::compute()
  {
    dealii::Timer total;
    create_output_directory();
    make_meshes();
    plan_contacts();
    for (const auto &task : results.tasks)
      solve_space(task, scene.output_directory);
    record_peak_memory();
    compute_seconds = total.wall_time();
  }

  // Every process writes its own rows of the .h5 (parallel HDF5 in a distributed run); process 0
  // alone writes the other files. The last space's VTU file may still be being written meanwhile.
  void ModalPrecompute::write()
  {
    write_results(compute_seconds);
  }

  void ModalPrecompute::mesh_only()
  {
    create_output_directory();
    make_meshes();
  }

  // One scenario from the meshes already in the output folder: jobs that ran gmsh each would not
  // share one display surface (gmsh is not bit-reproducible), so a missing mesh is an error.
  void ModalPrecompute::run_scenario(const std::string &name, const std::string &partial_directory)
  {
    dealii::Timer total;
    make_meshes(true);
    plan_contacts();
    const SpaceTask &task = task_of_scenario(name);
    if (writes_files)
      create_folder(partial_directory, "partial results folder");
    if (distributed) // all processes write the VTU into that folder
      MPI_Barrier(MPI_COMM_WORLD);
    solve_space(task, partial_directory);
    wait_for_vtu_files();
    record_peak_memory();
    if (distributed)
      gather_rows_on_root(results.spaces.front(), MPI_COMM_WORLD);
    if (!writes_files)
      return;
    PartialResult partial;
    partial.scene_name       = scene.scene_name;
    partial.parameters       = parameters_text();
    partial.display_checksum = display_surface_checksum(results.meshes.display_surface);
    partial.mesh_checksum    = file_checksum(task.msh_file);
    partial.n_processes      = results.n_processes;
    partial.peak_memory_mb   = results.max_peak_memory_mb;
    partial.seconds          = total.wall_time();
    partial.space            = std::move(results.spaces.front());
    write_partial_result(partial_result_file(partial_directory, name), partial);
  }

  // The partial results of every scenario, checked, then the files run() writes.
  void ModalPrecompute::merge(const std::string &partial_directory)
  {
    dealii::Timer total;
    create_output_directory();
    make_meshes(true);
    plan_contacts();
    double job_seconds = 0.;
    read_partial_results(partial_directory, job_seconds);
    write_results(job_seconds + total.wall_time(), partial_directory);
  }

  // The transfer matrices and every file of the scene, renamed into place together. The report is
  // written last: it gives the size of every other file and the total time.
  void ModalPrecompute::write_results(const double earlier_seconds, const std::string &jobs_directory)
  {
    dealii::Timer wall;
    add_transfer_matrices();
    StagedFiles staged;
    // The mode shapes' VTU files, written on a thread of their own, end before the report (it
    // holds their time) and before anything is renamed into place, not before the transfer matrices
    // and exports, which run while the last one is written (docs/performance.md).
    // Where an export fails, they end first too: their own failure (a full disk meets them first)
    // is the one reported, and no temporary file of theirs outlives the run.
    try
      {
        export_results(staged);
      }
    catch (...)
      {
        wait_for_vtu_files();
        throw;
      }
    wait_for_vtu_files();
    if (!writes_files)
      return;
    // The VTU files the scenario jobs wrote beside their partial results join the scene's files.
    if (!jobs_directory.empty())
      for (const auto &task : results.tasks)
        staged.write(vtu_file(scene.output_directory, task.name), [&](std::ostream &out) {
          const std::string job_file = vtu_file(jobs_directory, task.name);
          std::ifstream     in(job_file, std::ios::binary);
          AssertThrow(in, ExcMessage("Cannot read '" + job_file + "'."));
          out << in.rdbuf();
        }, std::ios::binary);
    results.timings_s["total"] = earlier_seconds + wall.wall_time();
    write_report(scene.output_directory + "/report.json", scene, results, staged);
    staged.commit();
  }

  std::string ModalPrecompute::parameters_text() const
  {
    std::ostringstream text;
    prm.print_parameters(text, dealii::ParameterHandler::ShortText);
    return text.str();
  }

  const SpaceTask &ModalPrecompute::task_of_scenario(const std::string &name) const
  {
    std::string names;
    for (const auto &task : results.tasks)
      {
        if (task.name == name)
          return task;
        names += (names.empty() ? "" : ", ") + task.name;
      }
    AssertThrow(false, ExcMessage("Scene '" + scene.scene_name + "' (" + scene.parameter_file + ") has no scenario '" +
                                  name + "'; its scenarios are: " + names + "."));
    return results.tasks.front();
  }

  namespace
  {
    // The first line where two parameter listings differ, for the message that refuses a merge.
    std::string first_difference(const std::string &ours, const std::string &theirs)
    {
      std::istringstream a(ours), b(theirs);
      std::string        line_a, line_b;
      while (true)
        {
          const bool more_a = bool(std::getline(a, line_a)), more_b = bool(std::getline(b, line_b));
          if (!more_a && !more_b)
            return "";
          if (!more_a || !more_b || line_a != line_b)
            return "'" + (more_b ? line_b : std::string("(nothing)")) + "' where the scene has '" +
                   (more_a ? line_a : std::string("(nothing)")) + "'";
        }
    }
  } // namespace

  // Every *.partial file of the folder: each must be of this scene, its parameters and its meshes,
  // and every scenario must be there exactly once.
  void ModalPrecompute::read_partial_results(const std::string &partial_directory, double &job_seconds)
  {
    TimerOutput::Scope scope(timer, "reading partial results");
    AssertThrow(std::filesystem::is_directory(partial_directory),
                ExcMessage("The partial results folder '" + partial_directory + "' does not exist."));
    std::vector<std::string> files;
    for (const auto &entry : std::filesystem::directory_iterator(partial_directory))
      if (entry.path().extension() == ".partial")
        files.push_back(entry.path().string());
    std::sort(files.begin(), files.end());

    const std::string                 parameters = parameters_text();
    const std::uint32_t               display    = display_surface_checksum(results.meshes.display_surface);
    std::vector<std::string>          file_of_space(results.tasks.size());
    std::vector<PartialResult>        partials(results.tasks.size());
    for (const auto &file : files)
      {
        PartialResult partial = read_partial_result(file);
        AssertThrow(partial.scene_name == scene.scene_name,
                    ExcMessage("'" + file + "' is a partial result of scene '" + partial.scene_name + "', not of '" +
                               scene.scene_name + "' (" + scene.parameter_file + ")."));
        const std::string difference = first_difference(parameters, partial.parameters);
        AssertThrow(difference.empty(),
                    ExcMessage("'" + file + "' was computed from other parameters than " + scene.parameter_file +
                               ": it has " + difference + ". Run its scenario again."));
        const SpaceTask &task = task_of_scenario(partial.space.name);
        AssertThrow(file_of_space[task.index].empty(),
                    ExcMessage("Scenario '" + task.name + "' is in two partial results, '" + file_of_space[task.index] +
                               "' and '" + file + "'; remove one."));
        AssertThrow(partial.display_checksum == display && partial.mesh_checksum == file_checksum(task.msh_file),
                    ExcMessage("'" + file + "' was computed on other meshes than those now in '" +
                               scene.output_directory + "' (" + task.msh_file +
                               ", display_surface.msh): the scene was meshed again since. Run its scenario again."));
        AssertThrow(std::filesystem::exists(vtu_file(partial_directory, task.name)),
                    ExcMessage("'" + vtu_file(partial_directory, task.name) + "', written with '" + file +
                               "', is missing."));
        file_of_space[task.index] = file;
        partials[task.index]      = std::move(partial);
      }
    std::string missing;
    for (const auto &task : results.tasks)
      if (file_of_space[task.index].empty())
        missing += (missing.empty() ? "'" : ", '") + task.name + "'";
    AssertThrow(missing.empty(),
                ExcMessage("No partial result in '" + partial_directory + "' for scenario(s) " + missing + " of scene '" +
                           scene.scene_name + "': run modal-precompute " + scene.parameter_file +
                           " --scenario NAME --partial-dir " + partial_directory + " for each."));

    results.n_processes        = 0;
    results.max_peak_memory_mb = 0.;
    for (auto &partial : partials)
      {
        results.n_processes        = std::max(results.n_processes, partial.n_processes);
        results.max_peak_memory_mb = std::max(results.max_peak_memory_mb, partial.peak_memory_mb);
        job_seconds += partial.seconds;
        for (const auto &[phase, seconds] : partial.space.timings_s)
          results.timings_s[phase] += seconds;
        results.spaces.push_back(std::move(partial.space));
      }
  }

  void ModalPrecompute::make_meshes(const bool reuse_only)
  {
    TimerOutput::Scope scope(timer, "meshing");
    dealii::Timer      wall;
    try
      {
        // Process 0 meshes (or finds the cached meshes); then the others read the same files from
        // the cache, so that gmsh never writes one file from two processes. A failure on process 0
        // aborts the run (main), so the barrier cannot hang.
        // A process not started by an MPI launcher may fork children that mesh the VOIs beside it
        // (under mpirun, even with one process, MPI libraries forbid fork or warn about it).
        meshing::MeshingSettings settings = scene.meshing;
        settings.mesh_vois_beside         = !started_by_mpi_launcher();
        if (writes_files && !shared_mesh_folder.empty() && !reuse_only)
          meshing::adopt_meshes(settings, scene.volumes_of_interest, shared_mesh_folder, scene.output_directory,
                                verbose);
        if (writes_files)
          results.meshes =
            meshing::mesh_scene(settings, scene.volumes_of_interest, scene.output_directory, verbose, reuse_only);
        if (distributed)
          MPI_Barrier(MPI_COMM_WORLD);
        if (!writes_files)
          results.meshes =
            meshing::mesh_scene(scene.meshing, scene.volumes_of_interest, scene.output_directory, false, reuse_only);
      }
    catch (const meshing::MeshingError &e)
      {
        AssertThrow(!reuse_only, ExcMessage(std::string(e.what()) + ". Mesh the scene first with 'modal-precompute " +
                                            scene.parameter_file + " --mesh-only' (with the same --output-dir): the "
                                            "scenario jobs must share one set of meshes, gmsh is not bit-reproducible."));
        AssertThrow(false, ExcMessage(std::string("Meshing failed: ") + e.what()));
      }
    results.display = make_display_surface(results.meshes.display_surface, scene.volumes_of_interest,
                                           scene.length_unit, scene.contact.patch_radius * scene.length_unit);
    results.timings_s["meshing"] = wall.wall_time();
    if (verbose)
      std::cout << "[display] " << results.display.n_vertices() << " vertices, " << results.display.triangles.size()
                << " triangles, contact patches of up to " << results.display.max_patch_size << " vertices" << std::endl;
    if (results.display.max_patch_size > ContactSurface::patch_size_warning)
      std::cerr << "Warning: a contact patch holds " << results.display.max_patch_size << " display vertices (more than "
                << ContactSurface::patch_size_warning << "): 'Contact/Patch radius' = " << scene.contact.patch_radius
                << " geometry units (" << scene.contact.patch_radius * scene.length_unit
                << " m) is large for the display surface's fine size; the .mrt and each contact's tick grow with it."
                << std::endl;
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

  unsigned int nearest_display_vertex(const ContactSurface &display, const meshing::Point3 &point,
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

  namespace
  {
    // Each point of 'Contact/Exact pair points' on the part: its nearest display vertex within 'Exact
    // pair reach' (a point off the surface would link no candidate, silently).
    void check_exact_pair_points(const ContactSurface &display, const SceneParameters &scene, const bool verbose)
    {
      const double unit = scene.length_unit, reach = scene.contact.exact_pair_reach;
      for (const auto &pair : scene.contact.exact_pairs)
        {
          std::array<unsigned int, 2> nearest{};
          for (unsigned int e = 0; e < 2; ++e)
            {
              const auto        &point = pair[e];
              const unsigned int v     = nearest_display_vertex(display, point, unit);
              const double       distance = std::hypot(display.vertices[v][0] - point[0] * unit,
                                                       display.vertices[v][1] - point[1] * unit,
                                                       display.vertices[v][2] - point[2] * unit) / unit;
              std::ostringstream message;
              message << "'Contact/Exact pair points': the point (" << point[0] << ", " << point[1] << ", " << point[2]
                      << ") lies " << distance << " (geometry units) from the nearest display vertex, beyond "
                      << "'Contact/Exact pair reach' = " << reach << ": it is not on the part's surface.";
              AssertThrow(distance <= reach, ExcMessage(message.str()));
              nearest[e] = v;
            }
          if (verbose)
            std::cout << "[contacts] exact pair (" << pair[0][0] << ", " << pair[0][1] << ", " << pair[0][2] << ") : ("
                      << pair[1][0] << ", " << pair[1][1] << ", " << pair[1][2] << ") -> display vertices " << nearest[0]
                      << " and " << nearest[1] << std::endl;
        }
    }
  } // namespace

  // A VOI space's candidates are the display vertices inside its VOI. The global space's are every
  // n-th vertex outside all VOIs and, with 'Global candidates in VOIs', every vertex inside one: two
  // HIPs in two regions make the kernel take the global space, whose contacts there must stay exact.
  std::vector<unsigned int> ModalPrecompute::candidates_of_space(const unsigned int space) const
  {
    const auto               &display = results.display;
    const unsigned int        stride  = scene.contact.global_candidate_stride;
    std::vector<unsigned int> candidates;
    unsigned int              seen_outside = 0;
    for (unsigned int v = 0; v < display.n_vertices(); ++v)
      {
        const unsigned int region = display.region[v];
        if (space > 0)
          {
            if (region == space)
              candidates.push_back(v);
          }
        else if (region > 0)
          {
            if (scene.contact.global_candidates_in_vois)
              candidates.push_back(v);
          }
        else if (stride > 0 && seen_outside++ % stride == 0)
          candidates.push_back(v);
      }
    return candidates;
  }

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
        task.candidates          = thin_evenly(candidates_of_space(s), scene.contact.maximum_candidates);
        task.validation_vertices = thin_evenly(task.candidates, scene.contact.validation_samples);
        shared.insert(shared.end(), task.validation_vertices.begin(), task.validation_vertices.end());
        results.tasks.push_back(task);
      }
    if (verbose) // one line for every space
      {
        std::cout << "[contacts]";
        for (const auto &task : results.tasks)
          std::cout << (task.index ? ";" : "") << " space '" << task.name << "': " << task.candidates.size()
                    << " candidates, " << task.validation_vertices.size() << " validated";
        std::cout << std::endl;
      }
    for (const auto &point : scene.contact.validation_points)
      {
        const unsigned int v = nearest_display_vertex(display, point, scene.length_unit);
        auto &task = results.tasks[display.region[v]];
        // The global space corrects VOI vertices too: a point there is solved afresh in it as well.
        for (auto *owner : {&task, scene.contact.global_candidates_in_vois ? &results.tasks.front() : &task})
          for (auto *list : {&owner->candidates, &owner->validation_vertices})
            if (std::find(list->begin(), list->end(), v) == list->end())
              {
                list->push_back(v);
                std::sort(list->begin(), list->end());
              }
        shared.push_back(v);
        if (scene.contact.validity_analysis &&
            std::find(task.validity_vertices.begin(), task.validity_vertices.end(), v) == task.validity_vertices.end())
          task.validity_vertices.push_back(v);
        if (verbose)
          std::cout << "[contacts] validation point (" << point[0] << ", " << point[1] << ", " << point[2]
                    << ") -> display vertex " << v << " in space '" << task.name << "'" << std::endl;
      }
    check_exact_pair_points(display, scene, verbose);
    std::sort(shared.begin(), shared.end());
    shared.erase(std::unique(shared.begin(), shared.end()), shared.end());
    for (auto &task : results.tasks)
      task.shared_vertices = shared;
  }

  void ModalPrecompute::solve_space(const SpaceTask &task, const std::string &vtu_directory)
  {
    if (verbose)
      std::cout << "[space " << task.index + 1 << "/" << results.tasks.size() << "] " << task.name << std::endl;
    ModalSpaceResult space =
      distributed ? compute_modal_space_distributed(scene, results.display, task, vtu_file(vtu_directory, task.name),
                                                    timer, verbose, MPI_COMM_WORLD) :
                    compute_modal_space(scene, results.display, task, vtu_file(vtu_directory, task.name), timer,
                                        verbose);
    for (const auto &[phase, seconds] : space.timings_s)
      results.timings_s[phase] += seconds;
    results.spaces.push_back(std::move(space));
  }

  // The spaces' VTU files are written while the next space computes (the serial path); the time the
  // run still waits for them counts as VTU output.
  void ModalPrecompute::wait_for_vtu_files()
  {
    TimerOutput::Scope scope(timer, "vtu_output");
    dealii::Timer      wall;
    BackgroundWrites::of_this_process().wait();
    results.timings_s["vtu_output"] += wall.wall_time();
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
  std::vector<TransferMatrix> compute_transfer_matrices(const ContactSurface &display,
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

  void ModalPrecompute::add_transfer_matrices()
  {
    TimerOutput::Scope scope(timer, "transfer matrices");
    results.transfers = compute_transfer_matrices(results.display, results.spaces);
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
    write_felt_stiffness_vtu(scene.output_directory + "/felt_stiffness.vtu", results, staged);
    write_validity_vtu(scene.output_directory + "/validity.vtu", results, staged);
    staged.write(scene.output_directory + "/used_parameters.prm",
                 [&](std::ostream &out) { print_used_parameters(prm, out); });
    for (const auto &task : results.tasks)
      {
        staged.write(scene.output_directory + "/modes_" + task.name + ".pvd", [&](std::ostream &out) {
        out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n"
            << "    <DataSet timestep=\"0\" group=\"\" part=\"0\" file=\"modes_" << task.name << ".vtu\"/>\n"
            << "  </Collection>\n</VTKFile>\n";
        });
      }
    results.timings_s["export"] = wall.wall_time();
  }

  FeltStiffnessMap felt_stiffness_map(const PrecomputeResults &results)
  {
    FeltStiffnessMap map;
    const auto      &display = results.display;
    for (unsigned int v = 0; v < display.n_vertices(); ++v)
      {
        map.vertices.insert(map.vertices.end(), display.vertices[v].begin(), display.vertices[v].end());
        // A vertex of a VOI is felt in its VOI's space; the global space has a value there too
        // ('Contact/Global candidates in VOIs'), taken where the VOI's has none.
        const double own = results.spaces[display.region[v]].felt_stiffness[v];
        map.stiffness.push_back(own > 0. ? own : results.spaces.front().felt_stiffness[v]);
      }
    for (const auto &t : display.triangles)
      map.triangles.insert(map.triangles.end(), t.begin(), t.end());
    map.region = display.region;
    for (const auto &space : results.spaces)
      map.region_names.push_back(space.name);
    return map;
  }

  namespace
  {
    bool writes_files_here() { return dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD) == 0; }

    std::vector<std::pair<std::string, std::string>> override_pairs(const std::vector<VariantOverride> &overrides)
    {
      std::vector<std::pair<std::string, std::string>> pairs;
      for (const auto &o : overrides)
        pairs.emplace_back(o.entry, o.value);
      return pairs;
    }

    // Whether every mesh of a run was made from the base's inputs (the same cache keys).
    bool same_meshes(const PrecomputeResults &a, const PrecomputeResults &b)
    {
      bool same = a.meshes.display_surface.cache_key == b.meshes.display_surface.cache_key &&
                  a.meshes.scenarios.size() == b.meshes.scenarios.size();
      for (std::size_t k = 0; same && k < a.meshes.scenarios.size(); ++k)
        same = a.meshes.scenarios[k].cache_key == b.meshes.scenarios[k].cache_key;
      return same;
    }

    // One line per comparison in the log, and one per region.
    void say_comparison(const std::string &name, const MapComparisonRecord &map)
    {
      std::ostringstream line;
      line << "[variants] " << name << " against the base (" << map.rule << ", " << map.all.compared_vertices
           << " vertices): ratio " << map.ratio_min << " .. " << map.ratio_median << " .. " << map.ratio_max << ": " << map.all.verdict;
      for (const auto &region : map.regions)
        line << "\n[variants]   " << region.name << ": |difference| p95 " << region.p95_abs_percent << " %, "
             << region.beyond_noise_vertices << " of " << region.compared_vertices << " vertices beyond the "
             << region.noise_floor_percent << " % floor: " << region.verdict;
      std::cout << line.str() << std::endl;
    }

    // A scene made from the base's file, computed and written into its own folder; its map, and the
    // record of the run beside the base's.
    struct DerivedRun
    {
      FeltStiffnessMap map;
      bool             meshes_reused = false;
      double           seconds       = 0.;
    };

    DerivedRun run_derived_scene(const VariantScene &derived, const ModalPrecompute &base, const SceneParameters &base_scene,
                                 const bool take_base_meshes, const bool verbose, const bool distributed)
    {
      if (verbose)
        std::cout << "[variants] '" << derived.name << "' into " << derived.scene->output_directory << "/" << std::endl;
      dealii::Timer   wall;
      ModalPrecompute run(*derived.scene, *derived.prm, verbose, distributed);
      if (take_base_meshes)
        run.take_meshes_from(base_scene.output_directory);
      DesignRecord record;
      record.variant_name = derived.name;
      record.overrides    = override_pairs(derived.overrides);
      record.base_folder  = base_scene.output_directory;
      run.set_design_record(std::move(record));
      run.run();
      // Only process 0 holds every row of a distributed run's map (and compares: an empty map compares nothing).
      return {writes_files_here() ? felt_stiffness_map(run.get_results()) : FeltStiffnessMap(),
              same_meshes(run.get_results(), base.get_results()), wall.wall_time()};
    }
  } // namespace

  void run_with_variants(const SceneParameters &base, const dealii::ParameterHandler &prm,
                         const std::vector<VariantScene> &variants, const VariantScene *noise_floor,
                         const double noise_floor_mesh_scale, const bool verbose, const bool distributed)
  {
    ModalPrecompute base_run(base, prm, verbose, distributed);
    base_run.compute();
    const FeltStiffnessMap base_map = writes_files_here() ? felt_stiffness_map(base_run.get_results()) : FeltStiffnessMap();
    DesignRecord           design;
    if (noise_floor)
      {
        // Another mesh of the same design: its own meshes, never the base's.
        const DerivedRun run = run_derived_scene(*noise_floor, base_run, base, false, verbose, distributed);
        design.noise_floor.measured   = true;
        design.noise_floor.mesh_scale = noise_floor_mesh_scale;
        design.noise_floor.folder     = noise_floor->scene->output_directory;
        design.noise_floor.seconds    = run.seconds;
        design.noise_floor.map        = compare_felt_stiffness(base_map, run.map, {});
        if (writes_files_here()) // a summary: printed under --quiet too
          say_comparison("the noise floor's mesh", design.noise_floor.map);
      }
    const std::vector<double> floors = design.noise_floor.floors_percent();
    for (const auto &variant : variants)
      {
        const DerivedRun  run = run_derived_scene(variant, base_run, base, true, verbose, distributed);
        VariantComparison comparison;
        comparison.name          = variant.name;
        comparison.folder        = variant.scene->output_directory;
        comparison.overrides     = override_pairs(variant.overrides);
        comparison.meshes_reused = run.meshes_reused;
        comparison.seconds       = run.seconds;
        comparison.map           = compare_felt_stiffness(base_map, run.map, floors);
        if (writes_files_here())
          say_comparison("'" + variant.name + "'", comparison.map);
        design.variants.push_back(std::move(comparison));
      }
    base_run.set_design_record(std::move(design));
    base_run.write();
  }
} // namespace modal_haptics
