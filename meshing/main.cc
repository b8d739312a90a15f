// modal-mesh: a developer tool that meshes the built-in ribbed panel with the two scenarios of
// parameters/ribbed_panel.prm and prints the statistics.
//   modal-mesh <output folder> [coarse size [fine size]]      (sizes in mm)
#include "scene_mesher.h"

#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

namespace
{
  const char *const usage = " <output folder> [coarse size [fine size]]   (sizes in mm; defaults 6 and 1.5)\n"
                            "Meshes the built-in ribbed panel with the scenarios rib_a and rib_b of "
                            "parameters/ribbed_panel.prm into the folder and prints the statistics.\n";

  // A size argument [mm]: a positive number, the whole argument, or an error that names it.
  double size_argument(const char *text, const std::string &name)
  {
    char        *end  = nullptr;
    const double size = std::strtod(text, &end);
    if (end == text || *end != '\0' || !(size > 0.))
      throw std::invalid_argument(name + " is '" + text + "': expected a positive number of mm.");
    return size;
  }
} // namespace

int main(int argc, char **argv)
{
  using namespace modal_haptics::meshing;
  const std::string first = argc > 1 ? argv[1] : "";
  if (first == "--help" || first == "-h")
    {
      std::cout << "usage: " << argv[0] << usage;
      return 0;
    }
  if (argc < 2 || argc > 4 || first.empty() || first[0] == '-')
    {
      if (!first.empty() && first[0] == '-')
        std::cerr << "modal-mesh: unknown option '" << first << "'\n";
      std::cerr << "usage: " << argv[0] << usage;
      return 2;
    }
  try
    {
      MeshingSettings settings;
      settings.geometry = "builtin:ribbed_panel";
      if (argc > 2)
        settings.coarse_size = size_argument(argv[2], "the coarse size (second argument)");
      const double fine = argc > 3 ? size_argument(argv[3], "the fine size (third argument)") : 1.5;

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

      const SceneMeshes meshes = mesh_scene(settings, {rib_a, rib_b}, argv[1], true);
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
