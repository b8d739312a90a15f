// modal-mesh: a developer tool that meshes the built-in ribbed panel with the two scenarios of
// parameters/ribbed_panel.prm and prints the statistics.
//   modal-mesh FOLDER [COARSE_MM (6) [FINE_MM (1.5)]]      (sizes in mm; modal-mesh --help)
#include "scene_mesher.h"

#include <mrt/command_line.h>

#include <iostream>
#include <string>

namespace
{
  // What the command line asks for: the folder and the two sizes [mm].
  struct Arguments
  {
    std::string folder;
    double      coarse = 6.0, fine = 1.5; // [mm]
  };

  mrt::cli::OptionTable option_table(Arguments &a)
  {
    mrt::cli::OptionTable t("modal-mesh", "Meshes the built-in ribbed panel with the scenarios rib_a and rib_b of "
                                          "parameters/ribbed_panel.prm into the folder and prints the statistics.");
    t.positional("FOLDER", "the output folder", [&a](const std::string &v) { a.folder = v; }).required();
    t.positional("COARSE_MM", "the coarse mesh size [mm]", {1e-3, 1e4, "mm"}, [&a](double v) { a.coarse = v; })
      .shown_default("6");
    t.positional("FINE_MM", "the VOIs' fine mesh size [mm]", {1e-3, 1e4, "mm"}, [&a](double v) { a.fine = v; })
      .shown_default("1.5");
    return t;
  }
} // namespace

int main(int argc, char **argv)
{
  using namespace modal_haptics::meshing;
  Arguments arguments;
  if (const int status = mrt::cli::parse_command_line(option_table(arguments), argc - 1, argv + 1); status >= 0)
    return status;
  try
    {
      MeshingSettings settings;
      settings.geometry    = "builtin:ribbed_panel";
      settings.coarse_size = arguments.coarse;
      const double fine    = arguments.fine;

      VolumeOfInterest rib_a, rib_b;
      rib_a.name      = "rib_a"; // the tallest rib's middle
      rib_a.box_lower = {-30., 40., -1.};
      rib_a.box_upper = {30., 60., 25.};
      rib_b.name      = "rib_b"; // the lowest rib, off-centre
      rib_b.box_lower = {40., -60., -1.};
      rib_b.box_upper = {100., -40., 13.};
      for (auto *voi : {&rib_a, &rib_b})
        {
          voi->fine_size  = fine;
          voi->transition = 15.;
        }

      const SceneMeshes meshes = mesh_scene(settings, {rib_a, rib_b}, arguments.folder, true);
      for (const auto &scenario : meshes.scenarios)
        std::cout << scenario.name << ": " << scenario.msh_file << ", " << scenario.statistics.n_nodes << " nodes, "
                  << scenario.statistics.n_tets << " tets, min quality " << scenario.statistics.min_quality << ", "
                  << scenario.statistics.seconds << " s" << (scenario.statistics.reused ? " (reused)" : "") << '\n';
      std::cout << "display surface: " << meshes.display_surface.msh_file << ", "
                << meshes.display_surface.vertices.size() << " vertices, "
                << meshes.display_surface.triangles.size() << " triangles\n";
    }
  catch (const std::exception &e)
    {
      std::cerr << "modal-mesh: " << e.what() << '\n';
      return 1;
    }
  return 0;
}
