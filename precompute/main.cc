// modal-precompute: a scene's .prm becomes validated modal bases.
//
//   modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet] [--distributed]
//   mpirun -np N modal-precompute SCENE.prm ...     (N > 1 implies --distributed; docs/cluster.md)
#include "factorization.h"
#include "modal_precompute.h"
#include "scene_parameters.h"

#include <deal.II/base/hdf5.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>


#include <csignal>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>

namespace
{
  void print_usage(std::ostream &out)
  {
    out << "usage: modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet] [--distributed]\n"
           "       mpirun -np N modal-precompute SCENE.prm ...\n"
           "  --validate     parse and check every parameter, then exit\n"
           "  --output-dir   where results go (default: results/<scene name>)\n"
           "  --quiet        no progress lines\n"
           "  --distributed  the MPI path (Trilinos, MUMPS, PARPACK) even on one process; implied by N > 1\n";
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
} // namespace

int main(int argc, char **argv)
{
  using namespace modal_haptics;
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  // A file that reaches the size limit (RLIMIT_FSIZE, a quota) would kill the program with SIGXFSZ
  // and no word of why; ignored, the write fails with EFBIG and the program says which file.
  std::signal(SIGXFSZ, SIG_IGN);
  std::string parameter_file, output_directory;
  bool        validate_only = false, verbose = true;
  const unsigned int n_processes = dealii::Utilities::MPI::n_mpi_processes(MPI_COMM_WORLD);
  const unsigned int process     = dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD);
  bool               distributed = n_processes > 1;
  for (int i = 1; i < argc; ++i)
    {
      const std::string arg = argv[i];
      if (arg == "--validate")
        validate_only = true;
      else if (arg == "--quiet")
        verbose = false;
      else if (arg == "--distributed")
        distributed = true;
      else if (arg == "--output-dir" && i + 1 < argc)
        output_directory = argv[++i];
      else if ((arg == "--help" || arg == "-h") && process == 0)
        {
          print_usage(std::cout);
          std::cout << "\nEvery parameter, its default, range and unit:\n";
          dealii::ParameterHandler prm;
          declare_scene_parameters(prm);
          prm.print_parameters(std::cout, dealii::ParameterHandler::Text);
          return 0;
        }
      else if (!arg.empty() && arg[0] != '-' && parameter_file.empty())
        parameter_file = arg;
      else if (arg == "--help" || arg == "-h")
        return 0;
      else
        {
          if (process == 0)
            {
              print_error("unknown or incomplete argument '" + arg + "'");
              print_usage(std::cerr);
            }
          return 2;
        }
    }
  if (parameter_file.empty())
    {
      if (process == 0)
        print_usage(std::cerr);
      return 2;
    }
  if (distributed)
    use_one_blas_thread_unless_set();

  // Reading the parameters is the same on every process: if one fails, all report it together and
  // exit normally (process 0 prints, or the first failing process when process 0 did not fail).
  dealii::ParameterHandler prm;
  SceneParameters          scene;
  std::string              parse_error;
  try
    {
      scene = read_scene_parameters(prm, parameter_file, output_directory);
    }
  catch (const std::exception &e)
    {
      parse_error = error_message(e);
    }
  const unsigned int first_failing = dealii::Utilities::MPI::min(parse_error.empty() ? n_processes : process, MPI_COMM_WORLD);
  if (first_failing < n_processes)
    {
      if (process == first_failing)
        print_error(parse_error);
      return 1;
    }
  if (validate_only)
    {
      if (process == 0)
        std::cout << parameter_file << ": valid (scene '" << scene.scene_name << "', "
                  << scene.volumes_of_interest.size() << " VOI scenarios + the global one)" << std::endl;
      return 0;
    }

  // Later errors may strike one process inside collective operations: it prints its message and
  // aborts every process (MPI_Abort), so that none waits forever.
  try
    {
      ModalPrecompute precompute(scene, prm, verbose && process == 0, distributed);
      precompute.run();
      if (process == 0)
        std::cout << "results in " << scene.output_directory << "/" << std::endl;
    }
  catch (const std::exception &e)
    {
      print_error(n_processes > 1 ? "(process " + std::to_string(process) + ") " + error_message(e) : error_message(e));
      if (n_processes > 1)
        MPI_Abort(MPI_COMM_WORLD, 1);
      end_now_if_hdf5_holds_a_file();
      return 1;
    }
  return 0;
}
