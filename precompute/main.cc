// modal-precompute: a scene's .prm becomes validated modal bases.
//
//   modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet]
#include "modal_precompute.h"
#include "scene_parameters.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/hdf5.h>
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
    out << "usage: modal-precompute SCENE.prm [--output-dir DIR] [--validate] [--quiet]\n"
           "  --validate     parse and check every parameter, then exit\n"
           "  --output-dir   where results go (default: results/<scene name>)\n"
           "  --quiet        no progress lines\n";
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
} // namespace

int main(int argc, char **argv)
{
  using namespace modal_haptics;
  // A file that reaches the size limit (RLIMIT_FSIZE, a quota) would kill the program with SIGXFSZ
  // and no word of why; ignored, the write fails with EFBIG and the program says which file.
  std::signal(SIGXFSZ, SIG_IGN);
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  std::string parameter_file, output_directory;
  bool        validate_only = false, verbose = true;
  for (int i = 1; i < argc; ++i)
    {
      const std::string arg = argv[i];
      if (arg == "--validate")
        validate_only = true;
      else if (arg == "--quiet")
        verbose = false;
      else if (arg == "--output-dir" && i + 1 < argc)
        output_directory = argv[++i];
      else if (arg == "--help" || arg == "-h")
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
      else
        {
          print_error("unknown or incomplete argument '" + arg + "'");
          print_usage(std::cerr);
          return 2;
        }
    }
  if (parameter_file.empty())
    {
      print_usage(std::cerr);
      return 2;
    }

  try
    {
      dealii::ParameterHandler prm;
      const SceneParameters    scene = read_scene_parameters(prm, parameter_file, output_directory);
      if (validate_only)
        {
          std::cout << parameter_file << ": valid (scene '" << scene.scene_name << "', "
                    << scene.volumes_of_interest.size() << " VOI scenarios + the global one)" << std::endl;
          return 0;
        }
      ModalPrecompute precompute(scene, prm, verbose);
      precompute.run();
      std::cout << "results in " << scene.output_directory << "/" << std::endl;
    }
  catch (const dealii::ExceptionBase &e)
    {
      // The user needs the message, not deal.II's source location.
      std::ostringstream message;
      e.print_info(message);
      print_error(message.str());
      end_now_if_hdf5_holds_a_file();
      return 1;
    }
  catch (const std::exception &e)
    {
      print_error(e.what());
      end_now_if_hdf5_holds_a_file();
      return 1;
    }
  return 0;
}
