// modal-precompute: a scene's .prm becomes validated modal bases.
//
//   modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet] [--gmsh-verbose] [--distributed]
//   mpirun -np N modal-precompute SCENE.prm ...     (N > 1 implies --distributed; docs/cluster.md)
//   modal-precompute SCENE.prm --mesh-only | --list-scenarios | --scenario NAME | --merge   (scenarios
//   as separate jobs, docs/cluster.md)
#include "solvers/factorization.h"
#include "pipeline/geometry_check.h"
#include "pipeline/modal_precompute.h"
#include "output/partial_result.h"
#include "parameters/scene_parameters.h"
#include "space/space_parts.h"

#include <deal.II/base/hdf5.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>


#include <csignal>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

namespace
{
  void print_usage(std::ostream &out)
  {
    out << "usage: modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet] [--gmsh-verbose] [--distributed]\n"
           "       mpirun -np N modal-precompute SCENE.prm ...\n"
           "  --validate     parse and check every parameter, load the geometry (no meshing) and check its unit,\n"
           "                 groups and selections and the rigid-body motions the supports leave free, then exit\n"
           "  --output-dir   where results go (default: results/<scene name>)\n"
           "  --quiet        no progress lines (meshing, eigensolver, phases, timings) and nothing of gmsh's; the\n"
           "                 summaries (geometry, what each support caught, the modes kept), warnings and errors remain\n"
           "  --gmsh-verbose gmsh's own progress and information lines (off by default; its warnings are shown)\n"
           "  --distributed  the MPI path (Trilinos, MUMPS, the block Krylov method or PARPACK) even on one process; implied by N > 1\n"
           "\n"
           "Scenarios as separate jobs (docs/cluster.md): mesh once, one job per scenario (each serial or under\n"
           "mpirun), then merge; the merged files equal those of one whole-scene run.\n"
           "       modal-precompute SCENE.prm --list-scenarios\n"
           "       modal-precompute SCENE.prm --mesh-only [--output-dir DIR]\n"
           "  [mpirun -np N] modal-precompute SCENE.prm --scenario NAME [--partial-dir P] [--output-dir DIR]\n"
           "       modal-precompute SCENE.prm --merge [--partial-dir P] [--output-dir DIR]\n"
           "  --list-scenarios  print the scene's scenario names, one per line (global first), then exit\n"
           "  --mesh-only       make (or find up to date) every mesh of the scene in the output folder, then exit\n"
           "  --scenario NAME   compute only scenario NAME's modal space, from the meshes in the output folder\n"
           "                    (it never meshes: run --mesh-only first), into P/NAME.partial and P/modes_NAME.vtu\n"
           "  --merge           check the partial results in P (every scenario exactly once, the same parameters\n"
           "                    and meshes), compute the transfer matrices and write the .h5, .mrt, report.json,\n"
           "                    .pvd/.vtu and used_parameters.prm into the output folder, all renamed into place\n"
           "                    together; one process\n"
           "  --partial-dir P   the folder of the partial results (default: <output folder>/partial)\n";
  }

  void print_error(const std::string &what)
  {
    std::cerr << "\n----------------------------------------------------\n"
              << "modal-precompute: error\n"
              << what << "\n----------------------------------------------------" << std::endl;
  }

  // HDF5 keeps a file it failed to write (a full disk) open, and its clean-up in MPI_Finalize then
  // crashes on it (SIGSEGV, after the error was reported). By the time the error is reported every
  // other output is closed and the temporaries are removed, so the program ends at once.
  void end_now_if_hdf5_holds_a_file()
  {
    if (H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) > 0)
      {
        std::cout.flush();
        std::_Exit(1);
      }
  }

  std::string error_message(const std::exception &e)
  {
    // The user needs the message, not deal.II's source location.
    if (const auto *deal_ii = dynamic_cast<const dealii::ExceptionBase *>(&e))
      {
        std::ostringstream message;
        deal_ii->print_info(message);
        return message.str();
      }
    return e.what();
  }

  // One BLAS thread per MPI process: processes already fill the cores, and OpenBLAS threads on top
  // of them oversubscribe the machine (MUMPS calls BLAS). The environment variable is read when
  // OpenBLAS loads, before main, so the running library is told directly; a value the user set wins.
  void use_one_blas_thread_unless_set()
  {
    if (std::getenv("OPENBLAS_NUM_THREADS") != nullptr)
      return;
    setenv("OPENBLAS_NUM_THREADS", "1", 0);
    modal_haptics::set_openblas_threads(1);
  }

  // This process's place among the MPI processes.
  struct Processes
  {
    unsigned int count = dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD);
    unsigned int rank  = dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD);
  };

  // What the command line asks for.
  struct CommandLine
  {
    std::string parameter_file, output_directory, scenario, partial_directory;
    bool        validate_only = false, verbose = true, list_scenarios = false, mesh_only = false, merge = false;
    bool        distributed   = false;
  };

  // A usage error: one framed message and the usage on process 0; exit code 2.
  int usage_error(const Processes &processes, const std::string &what)
  {
    if (processes.rank == 0)
      {
        print_error(what);
        print_usage(std::cerr);
      }
    return 2;
  }

  // --help: the usage, every parameter with its default and unit (a .prm template), then the values
  // each accepts (its Pattern: the range), on process 0.
  int print_help(const Processes &processes)
  {
    if (processes.rank != 0)
      return 0;
    print_usage(std::cout);
    std::cout << "\nEvery parameter, its default and unit:\n";
    dealii::ParameterHandler prm;
    modal_haptics::declare_scene_parameters(prm);
    prm.print_parameters(std::cout, dealii::ParameterHandler::Text);
    std::cout << "\nThe values each parameter accepts (its range):\n";
    prm.print_parameters(std::cout, dealii::ParameterHandler::Description);
    return 0;
  }

  // Reads the arguments into `command`, in order; returns an exit code when the program is done
  // (--help, or an unknown argument).
  std::optional<int> read_arguments(int argc, char **argv, const Processes &processes, CommandLine &command)
  {
    command.distributed = processes.count > 1;
    for (int i = 1; i < argc; ++i)
      {
        const std::string arg = argv[i];
        if (arg == "--validate")
          command.validate_only = true;
        else if (arg == "--quiet")
          command.verbose = false;
        else if (arg == "--gmsh-verbose")
          modal_haptics::meshing::show_gmsh_log(true);
        else if (arg == "--distributed")
          command.distributed = true;
        else if (arg == "--list-scenarios")
          command.list_scenarios = true;
        else if (arg == "--mesh-only")
          command.mesh_only = true;
        else if (arg == "--merge")
          command.merge = true;
        else if (arg == "--output-dir" && i + 1 < argc)
          command.output_directory = argv[++i];
        else if (arg == "--scenario" && i + 1 < argc)
          command.scenario = argv[++i];
        else if (arg == "--partial-dir" && i + 1 < argc)
          command.partial_directory = argv[++i];
        else if (arg == "--help" || arg == "-h")
          return print_help(processes);
        else if (!arg.empty() && arg[0] != '-' && command.parameter_file.empty())
          command.parameter_file = arg;
        else
          return usage_error(processes, "unknown or incomplete argument '" + arg + "'");
      }
    return std::nullopt;
  }

  // The checks between arguments; returns an exit code when they do not go together.
  std::optional<int> check_arguments(const CommandLine &command, const Processes &processes)
  {
    if (command.parameter_file.empty())
      {
        if (processes.rank == 0)
          print_usage(std::cerr);
        return 2;
      }
    if (command.validate_only + command.list_scenarios + command.mesh_only + !command.scenario.empty() +
          command.merge > 1)
      return usage_error(processes,
                         "--validate, --list-scenarios, --mesh-only, --scenario and --merge exclude each other");
    if (!command.partial_directory.empty() && command.scenario.empty() && !command.merge)
      return usage_error(processes, "--partial-dir goes with --scenario or --merge");
    if (command.merge && processes.count > 1)
      return usage_error(processes, "--merge computes no modal space: run it on one process, without mpirun -np " +
                                      std::to_string(processes.count));
    return std::nullopt;
  }

  // A step that is the same on every process: if one fails, all report it together and exit normally
  // (process 0 prints, or the first failing process when process 0 did not fail).
  bool on_every_process(const Processes &processes, const std::function<void()> &step)
  {
    std::string error;
    try
      {
        step();
      }
    catch (const std::exception &e)
      {
        error = error_message(e);
      }
    const unsigned int first_failing =
      dealii::Utilities::MPI::min(error.empty() ? processes.count : processes.rank, MPI_COMM_WORLD);
    if (first_failing < processes.count && processes.rank == first_failing)
      print_error(error);
    return first_failing == processes.count;
  }

  // The scene as written (the base design) and the scenes of its variants and of its noise floor,
  // every override checked here, before anything is meshed.
  struct Designs
  {
    modal_haptics::VariantParameters                declared;
    std::vector<modal_haptics::VariantScene>        variants;
    std::optional<modal_haptics::VariantScene>      noise_floor;
  };

  Designs read_designs(dealii::ParameterHandler &prm, const modal_haptics::SceneParameters &base)
  {
    Designs designs;
    designs.declared.parse_parameters(prm, base.parameter_file);
    for (const auto &variant : designs.declared.variants)
      designs.variants.push_back(modal_haptics::read_variant_scene(
        base, variant.name, variant.overrides, base.output_directory + "/variants/" + variant.name));
    if (designs.declared.noise_floor)
      designs.noise_floor = modal_haptics::read_variant_scene(
        base, "noise_floor", modal_haptics::noise_floor_overrides(prm, base, designs.declared.noise_floor_mesh_scale),
        base.output_directory + "/noise_floor", false);
    return designs;
  }

  bool read_parameters_on_every_process(const CommandLine &command, const Processes &processes,
                                        dealii::ParameterHandler &prm, modal_haptics::SceneParameters &scene,
                                        Designs &designs)
  {
    return on_every_process(processes, [&] {
      scene   = modal_haptics::read_scene_parameters(prm, command.parameter_file, command.output_directory);
      designs = read_designs(prm, scene);
    });
  }

  // --list-scenarios and --validate answer from the parameters alone; returns their exit code.
  std::optional<int> answer_from_parameters(const CommandLine &command, const Processes &processes,
                                            const modal_haptics::SceneParameters &scene, const Designs &designs)
  {
    if (command.list_scenarios)
      {
        if (processes.rank == 0)
          {
            std::cout << "global\n";
            for (const auto &voi : scene.volumes_of_interest)
              std::cout << voi.name << "\n";
          }
        return 0;
      }
    if (command.validate_only)
      {
        if (!on_every_process(processes, [&] { modal_haptics::check_geometry(scene, processes.rank == 0, true); }))
          return 1;
        if (processes.rank == 0)
          std::cout << command.parameter_file << ": valid (scene '" << scene.scene_name << "', "
                    << scene.volumes_of_interest.size() << " VOI scenarios + the global one"
                    << (designs.declared.any() ? "; " + std::to_string(designs.variants.size()) + " design variants" +
                                                   (designs.noise_floor ? " and the noise floor" : "") :
                                                 std::string())
                    << ")" << std::endl;
        return 0;
      }
    return std::nullopt;
  }

  // Runs the mode the command line chose; returns the closing line (where the results are).
  std::string run_mode(const CommandLine &command, const Processes &processes,
                       const modal_haptics::SceneParameters &scene, dealii::ParameterHandler &prm,
                       const Designs &designs)
  {
    if (const auto blas = modal_haptics::running_blas_kernels(); blas.chosen_by_us && command.verbose && processes.rank == 0)
      std::cout << "[blas] OpenBLAS did not know this CPU and took its generic Prescott kernels: running with "
                   "OPENBLAS_CORETYPE="
                << blas.core << " (set OPENBLAS_CORETYPE yourself to choose)" << std::endl;
    // A whole run of a scene with variants computes them too; the scenario jobs' modes, the base alone.
    const bool whole_run = !command.mesh_only && command.scenario.empty() && !command.merge;
    if (whole_run && designs.declared.any())
      {
        modal_haptics::run_with_variants(scene, prm, designs.variants,
                                         designs.noise_floor ? &*designs.noise_floor : nullptr,
                                         designs.declared.noise_floor_mesh_scale,
                                         command.verbose && processes.rank == 0, command.distributed);
        return "results in " + scene.output_directory + "/, each variant's in its folder of " +
               scene.output_directory + "/variants/";
      }
    modal_haptics::ModalPrecompute precompute(scene, prm, command.verbose && processes.rank == 0,
                                              command.distributed);
    if (command.mesh_only)
      {
        precompute.mesh_only();
        return "meshes in " + scene.output_directory + "/";
      }
    if (!command.scenario.empty())
      {
        precompute.run_scenario(command.scenario, command.partial_directory);
        return "partial result in " +
               modal_haptics::partial_result_file(command.partial_directory, command.scenario);
      }
    if (command.merge)
      {
        precompute.merge(command.partial_directory);
        return "merged " + command.partial_directory + "/ into " + scene.output_directory + "/";
      }
    precompute.run();
    return "results in " + scene.output_directory + "/";
  }

  // Errors during the run may strike one process inside collective operations: it prints its message
  // and aborts every process (MPI_Abort), so that none waits forever.
  int run_and_report(const CommandLine &command, const Processes &processes,
                     const modal_haptics::SceneParameters &scene, dealii::ParameterHandler &prm, const Designs &designs)
  {
    try
      {
        const std::string done = run_mode(command, processes, scene, prm, designs);
        if (processes.rank == 0)
          std::cout << done << std::endl;
      }
    catch (const std::exception &e)
      {
        print_error(processes.count > 1 ? "(process " + std::to_string(processes.rank) + ") " + error_message(e) :
                                          error_message(e));
        if (processes.count > 1)
          MPI_Abort(MPI_COMM_WORLD, 1);
        end_now_if_hdf5_holds_a_file();
        return 1;
      }
    return 0;
  }
} // namespace

int main(int argc, char **argv)
{
  modal_haptics::apply_openblas_settings(argv);
  // deal.II's default thread count: the node's cores shared among its MPI processes (2 for one
  // process on 2 cores, 1 each under mpirun -np 2). DEAL_II_NUM_THREADS lowers it. The triangular
  // solves and the M products run on these threads.
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv);
  // A file that reaches the size limit (RLIMIT_FSIZE, a quota) would kill the program with SIGXFSZ
  // and no word of why; ignored, the write fails with EFBIG and the program says which file.
  std::signal(SIGXFSZ, SIG_IGN);

  const Processes processes;
  CommandLine     command;
  if (const auto done = read_arguments(argc, argv, processes, command))
    return *done;
  if (const auto done = check_arguments(command, processes))
    return *done;
  if (command.distributed)
    use_one_blas_thread_unless_set();

  modal_haptics::space_parts::print_space_summaries(true);
  dealii::ParameterHandler        prm;
  modal_haptics::SceneParameters scene;
  Designs                        designs;
  if (!read_parameters_on_every_process(command, processes, prm, scene, designs))
    return 1;
  if (const auto done = answer_from_parameters(command, processes, scene, designs))
    return *done;
  if (!on_every_process(processes, [&] { modal_haptics::check_geometry(scene, processes.rank == 0, false); }))
    return 1;
  if (command.partial_directory.empty())
    command.partial_directory = scene.output_directory + "/partial";
  return run_and_report(command, processes, scene, prm, designs);
}
