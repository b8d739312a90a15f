// modal-mesh: a developer tool that meshes the built-in ribbed panel with the two scenarios of
// parameters/ribbed_panel.prm and prints the statistics.
//   modal-mesh <output folder> [coarse size [fine size]]      (sizes in mm)
#include "scene_mesher.h"

#include <iostream>
#include <string>

int main(int argc, char **argv)
{
  using namespace modal_haptics::meshing;
  if (argc < 2 || argc > 4)
    {
      std::cerr << "usage: " << argv[0] << " <output folder> [coarse size [fine size]]   (mm)\n";
      return 2;
    }
  try
    {
      MeshingSettings settings;
      settings.geometry = "builtin:ribbed_panel";
      if (argc > 2)
        settings.coarse_size = std::stod(argv[2]);
      const double fine = argc > 3 ? std::stod(argv[3]) : 1.5;

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
