// Tests of the meshing stage (meshing/scene_mesher.h) on the built-in ribbed panel, coarse enough
// to run in seconds: files, groups, grading, quality, display surface, cache, the VOIs meshed in
// child processes, and the user errors.
#include "meshing_check.h"
#include "scene_mesher.h"

#include <sched.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <string>

using namespace modal_haptics::meshing;
namespace fs = std::filesystem;

using meshing_test::check;
using meshing_test::failures;

namespace
{
  // Expects a MeshingError whose message contains every one of 'words'.
  void check_throws(const std::function<void()> &action, const std::vector<std::string> &words, const std::string &what)
  {
    try
      {
        action();
        check(false, what + " (no exception)");
      }
    catch (const MeshingError &e)
      {
        bool all = true;
        for (const auto &word : words)
          all = all && std::string(e.what()).find(word) != std::string::npos;
        check(all, what + " -> \"" + e.what() + "\"");
      }
  }

  double seconds_of(const std::function<void()> &action)
  {
    const auto start = std::chrono::steady_clock::now();
    action();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  std::size_t vertices_inside(const DisplaySurface &surface, const VolumeOfInterest &voi)
  {
    std::size_t n = 0;
    for (const auto &p : surface.vertices)
      n += voi.contains(p) ? 1 : 0;
    return n;
  }

  // Closed and consistently oriented: every directed edge appears once and its reverse once.
  bool is_closed_and_consistent(const DisplaySurface &surface)
  {
    std::map<std::pair<unsigned int, unsigned int>, int> directed;
    for (const auto &t : surface.triangles)
      for (int i = 0; i < 3; ++i)
        ++directed[{t[i], t[(i + 1) % 3]}];
    for (const auto &[edge, count] : directed)
      {
        const auto reverse = directed.find({edge.second, edge.first});
        if (count != 1 || reverse == directed.end() || reverse->second != 1)
          return false;
      }
    return !surface.triangles.empty();
  }

  // Sum over triangles of centroid . (area normal) = 3 x enclosed volume: > 0 when outward.
  double enclosed_volume(const DisplaySurface &surface)
  {
    double six_volume = 0.;
    for (const auto &t : surface.triangles)
      {
        const Point3 &a = surface.vertices[t[0]], &b = surface.vertices[t[1]], &c = surface.vertices[t[2]];
        six_volume += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                      a[2] * (b[0] * c[1] - b[1] * c[0]);
      }
    return six_volume / 6.;
  }

  MeshingSettings coarse_panel()
  {
    MeshingSettings settings;
    settings.geometry    = "builtin:ribbed_panel";
    settings.coarse_size = 8.;
    return settings;
  }

  VolumeOfInterest box_around_middle_rib()
  {
    VolumeOfInterest voi;
    voi.name       = "rib_mid"; // the 14 mm rib at y = 0, its middle
    voi.box_lower  = {-20., -5., -1.};
    voi.box_upper  = {20., 5., 18.};
    voi.fine_size  = 2.;
    voi.transition = 10.;
    return voi;
  }

  void test_volume_of_interest_contains()
  {
    std::cout << "VolumeOfInterest::contains" << std::endl;
    VolumeOfInterest box = box_around_middle_rib();
    check(box.contains({0., 0., 0.}) && !box.contains({0., 6., 0.}) && box.contains({0., 5.5, 0.}, 1.),
          "box contains, with tolerance");
    VolumeOfInterest ball;
    ball.shape       = VolumeOfInterest::Shape::ball;
    ball.ball_centre = {1., 1., 1.};
    ball.ball_radius = 2.;
    check(ball.contains({2., 2., 2.}) && !ball.contains({3., 3., 3.}), "ball contains");
  }

  void test_ribbed_panel(const fs::path &folder)
  {
    std::cout << "built-in panel, global + one VOI" << std::endl;
    const MeshingSettings  settings = coarse_panel();
    const VolumeOfInterest voi      = box_around_middle_rib();
    const std::string      dir      = folder.string();

    // The display surface of the scene without VOI: what the global mesh offers inside the box.
    const SceneMeshes global_only = mesh_scene(settings, {}, dir, true);
    const std::size_t coarse_inside = vertices_inside(global_only.display_surface, voi);

    SceneMeshes meshes;
    const double first_seconds = seconds_of([&] { meshes = mesh_scene(settings, {voi}, dir, true); });
    check(meshes.scenarios.size() == 2 && meshes.scenarios[0].name == "global" && meshes.scenarios[1].name == voi.name,
          "scenarios are global, then the VOI");
    for (const auto *file : {"mesh_global.msh", "mesh_global.key", "mesh_rib_mid.msh", "mesh_rib_mid.key",
                             "display_surface.msh", "display_surface.key"})
      check(fs::exists(folder / file), std::string(file) + " exists");
    // The stage's output names the cache key of every mesh: the one its key file holds.
    const auto key_in_file = [&](const std::string &file) {
      std::ifstream input(folder / file);
      std::string   word, key;
      while (input >> word)
        if (word == "key")
          input >> key;
      return key;
    };
    check(!meshes.scenarios[0].cache_key.empty() && meshes.scenarios[0].cache_key == key_in_file("mesh_global.key") &&
            meshes.scenarios[1].cache_key == key_in_file("mesh_rib_mid.key") &&
            meshes.display_surface.cache_key == key_in_file("display_surface.key") &&
            meshes.scenarios[0].cache_key != meshes.scenarios[1].cache_key,
          "each mesh's cache key is its key file's");
    check(meshes.scenarios[0].statistics.reused, "the global mesh of the first call is reused");

    for (const auto &scenario : meshes.scenarios)
      {
        check(scenario.physical_volumes.count("part") == 1, scenario.name + ": volume group 'part'");
        check(scenario.physical_surfaces.count("clamp") == 1 && scenario.physical_surfaces.count("free") == 1,
              scenario.name + ": surface groups 'clamp' and 'free'");
        check(scenario.statistics.min_quality > 0. &&
                scenario.statistics.min_quality <= scenario.statistics.mean_quality &&
                scenario.statistics.mean_quality <= scenario.statistics.max_quality,
              scenario.name + ": quality 0 < min <= mean <= max (min " +
                std::to_string(scenario.statistics.min_quality) + ")");
      }
    const auto names = read_physical_names(meshes.scenarios[1].msh_file);
    check(names.count(2) && names.at(2).count("clamp") && names.at(2).at("clamp") >= 1, "file names 'clamp' (tag >= 1)");
    check(meshes.scenarios[1].statistics.n_tets > meshes.scenarios[0].statistics.n_tets,
          "the VOI mesh has more tets (" + std::to_string(meshes.scenarios[1].statistics.n_tets) + ") than the global (" +
            std::to_string(meshes.scenarios[0].statistics.n_tets) + ")");

    const DisplaySurface &surface = meshes.display_surface;
    check(is_closed_and_consistent(surface), "display surface: closed, every edge in two opposite triangles");
    check(enclosed_volume(surface) > 0., "display surface: outward (enclosed volume " +
                                           std::to_string(enclosed_volume(surface)) + " mm^3)");
    check(vertices_inside(surface, voi) > coarse_inside,
          "display surface: " + std::to_string(vertices_inside(surface, voi)) + " vertices inside the VOI, " +
            std::to_string(coarse_inside) + " without the VOI");

    SceneMeshes again;
    const double second_seconds = seconds_of([&] { again = mesh_scene(settings, {voi}, dir, false); });
    check(again.scenarios[0].statistics.reused && again.scenarios[1].statistics.reused &&
            again.display_surface.statistics.reused,
          "a second call reuses every mesh");
    check(again.scenarios[1].statistics.n_tets == meshes.scenarios[1].statistics.n_tets &&
            again.display_surface.vertices == surface.vertices && again.display_surface.triangles == surface.triangles,
          "the reused meshes are the same");
    check(second_seconds < 2. && second_seconds < first_seconds,
          "the second call is fast (" + std::to_string(second_seconds) + " s, first " + std::to_string(first_seconds) +
            " s)");

    VolumeOfInterest finer = voi;
    finer.fine_size        = 1.5;
    const SceneMeshes regraded = mesh_scene(settings, {finer}, dir, false);
    check(regraded.scenarios[0].statistics.reused && !regraded.scenarios[1].statistics.reused &&
            !regraded.display_surface.statistics.reused,
          "a new fine size re-meshes the VOI and the display surface, not the global mesh");
  }

  // The VOIs meshed by child processes beside the global mesh and the display surface
  // (MeshingSettings::mesh_vois_beside; with one core allowed, in this process as before): the same
  // scenarios in the same order, made (not reused) and cached, then reused; a VOI that cannot be
  // meshed is still the error that names it.
  void test_vois_beside(const fs::path &folder)
  {
    cpu_set_t cores;
    CPU_ZERO(&cores);
    const int n_cores = sched_getaffinity(0, sizeof(cores), &cores) == 0 ? CPU_COUNT(&cores) : 1;
    std::cout << "VOIs meshed beside (" << n_cores << " cores allowed)" << std::endl;
    MeshingSettings settings  = coarse_panel();
    settings.mesh_vois_beside = true;
    VolumeOfInterest second   = box_around_middle_rib();
    second.name               = "rib_end";
    second.box_lower          = {60., -5., -1.};
    second.box_upper          = {100., 5., 18.};
    const std::vector<VolumeOfInterest> vois = {box_around_middle_rib(), second};
    const std::string                   dir  = (folder / "beside").string();

    const SceneMeshes meshes = mesh_scene(settings, vois, dir, true);
    check(meshes.scenarios.size() == 3 && meshes.scenarios[0].name == "global" &&
            meshes.scenarios[1].name == "rib_mid" && meshes.scenarios[2].name == "rib_end",
          "beside: scenarios are global, then the VOIs in their order");
    bool made = true;
    for (const auto &scenario : meshes.scenarios)
      made = made && !scenario.statistics.reused && scenario.statistics.n_tets > 0 &&
             scenario.statistics.min_quality > settings.min_quality &&
             scenario.physical_surfaces.count("clamp") == 1 && fs::exists(scenario.msh_file);
    check(made, "beside: every scenario made in this call (not reused), with its groups and quality");
    const bool children_possible = n_cores > 1 && settings.mesh_threads == 1;
    check(!meshes.scenarios[0].statistics.made_in_child_process &&
            (meshes.scenarios[1].statistics.made_in_child_process ||
             meshes.scenarios[2].statistics.made_in_child_process) == children_possible,
          "beside: a child process made a VOI's mesh exactly where more than one core is allowed");
    check(!meshes.display_surface.vertices.empty() && is_closed_and_consistent(meshes.display_surface),
          "beside: the display surface is made and closed");
    const SceneMeshes again = mesh_scene(settings, vois, dir, false);
    check(again.scenarios.size() == 3 && again.scenarios[1].statistics.reused && again.scenarios[2].statistics.reused &&
            again.scenarios[2].statistics.n_tets == meshes.scenarios[2].statistics.n_tets,
          "beside: a second call reuses the VOIs' meshes");
    check(!again.scenarios[1].statistics.made_in_child_process && !again.scenarios[2].statistics.made_in_child_process,
          "beside: a reused mesh was made by no child process");

    VolumeOfInterest above_plate = second; // inside the part's bounding box, but in the air
    above_plate.name             = "above_plate";
    above_plate.box_lower        = {-100., -30., 18.};
    above_plate.box_upper        = {-90., -20., 19.};
    check_throws([&] { mesh_scene(settings, {box_around_middle_rib(), above_plate}, dir, false); },
                 {"VOI", "above_plate"}, "beside: a VOI that misses the part is the error naming it");
  }

  void test_user_errors(const fs::path &folder)
  {
    std::cout << "user errors" << std::endl;
    const MeshingSettings settings = coarse_panel();
    VolumeOfInterest      far_away = box_around_middle_rib();
    far_away.name                  = "in_the_air";
    far_away.box_lower             = {0., 0., 500.};
    far_away.box_upper             = {10., 10., 510.};
    check_throws([&] { mesh_scene(settings, {far_away}, folder.string(), false); }, {"VOI", "in_the_air"},
                 "a VOI away from the part");

    VolumeOfInterest above_plate = far_away; // inside the part's bounding box, but in the air
    above_plate.name             = "above_plate";
    above_plate.box_lower        = {-100., -30., 18.};
    above_plate.box_upper        = {-90., -20., 19.};
    check_throws([&] { mesh_scene(settings, {above_plate}, folder.string(), false); }, {"VOI", "above_plate"},
                 "a VOI inside the bounding box that misses the part");

    MeshingSettings missing = settings;
    missing.geometry        = (folder / "no_such_part.step").string();
    check_throws([&] { mesh_scene(missing, {}, folder.string(), false); }, {missing.geometry}, "a missing STEP file");
    check_throws([&] { read_physical_names((folder / "none.msh").string()); }, {"none.msh"}, "a missing .msh file");
  }

  // Two tets sharing the face (1, 2, 3); the second one is given inverted unless 'valid'.
  std::string write_two_tets(const fs::path &file, const bool valid)
  {
    std::ofstream msh(file);
    msh << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
        << "$PhysicalNames\n1\n3 1 \"part\"\n$EndPhysicalNames\n"
        << "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0 0 -1\n$EndNodes\n"
        << "$Elements\n2\n3 4 2 1 1 1 2 3 4\n" << (valid ? "7 4 2 1 1 1 3 2 5\n" : "7 4 2 1 1 1 2 3 5\n")
        << "$EndElements\n";
    return file.string();
  }

  void test_msh_input(const fs::path &folder)
  {
    std::cout << ".msh input and check_mesh_quality" << std::endl;
    const std::string inverted = write_two_tets(folder / "inverted.msh", false);
    check_throws([&] { check_mesh_quality(inverted, 0.01); }, {"inverted.msh", "tetrahedron 7", "inverted"},
                 "an inverted tet is named");

    const std::string    good       = write_two_tets(folder / "good.msh", true);
    const MeshStatistics statistics = check_mesh_quality(good, 0.01);
    check(statistics.n_tets == 2 && statistics.n_nodes == 5 && statistics.min_quality > 0.5,
          "a valid .msh passes (min quality " + std::to_string(statistics.min_quality) + ")");

    MeshingSettings settings;
    settings.geometry = good;
    check_throws([&] { mesh_scene(settings, {box_around_middle_rib()}, (folder / "from_msh").string(), false); },
                 {"re-grade", "rib_mid"}, "a VOI on a .msh input");
    const SceneMeshes meshes = mesh_scene(settings, {}, (folder / "from_msh").string(), false);
    check(fs::exists(meshes.scenarios[0].msh_file) && meshes.scenarios[0].physical_volumes.count("part") == 1,
          ".msh input copied as the global mesh, names kept");
    check(meshes.display_surface.triangles.size() == 6 && is_closed_and_consistent(meshes.display_surface) &&
            enclosed_volume(meshes.display_surface) > 0.,
          ".msh input: display surface = outward boundary of the tets");
  }

  void test_geo_input(const fs::path &folder)
  {
    std::cout << ".geo input" << std::endl;
    const fs::path geo = folder / "block.geo";
    std::ofstream(geo) << "SetFactory(\"OpenCASCADE\");\nBox(1) = {0, 0, 0, 40, 10, 5};\n"
                       << "Physical Volume(\"part\", 1) = {1};\nPhysical Surface(\"clamp\", 1) = {1};\n";
    MeshingSettings settings;
    settings.geometry    = geo.string();
    settings.coarse_size = 4.;
    const SceneMeshes meshes = mesh_scene(settings, {}, (folder / "from_geo").string(), false);
    const auto       &groups = meshes.scenarios[0].physical_surfaces;
    check(groups.count("clamp") == 1 && groups.count("free") == 1, ".geo groups kept, the rest of the boundary is 'free'");
    check(is_closed_and_consistent(meshes.display_surface) && std::abs(enclosed_volume(meshes.display_surface) - 2000.) < 1e-6,
          ".geo display surface encloses the block (" + std::to_string(enclosed_volume(meshes.display_surface)) + ")");

    const fs::path unnamed = folder / "unnamed.geo";
    std::ofstream(unnamed) << "SetFactory(\"OpenCASCADE\");\nBox(1) = {0, 0, 0, 40, 10, 5};\nPhysical Volume(3) = {1};\n";
    settings.geometry = unnamed.string();
    check_throws([&] { mesh_scene(settings, {}, (folder / "from_geo").string(), false); }, {"unnamed.geo", "name"},
                 "an unnamed physical group in a .geo");
  }
} // namespace

int main()
{
  const fs::path folder = fs::temp_directory_path() / ("modal_meshing_test_" + std::to_string(::getpid()));
  fs::create_directories(folder);
  try
    {
      test_volume_of_interest_contains();
      test_ribbed_panel(folder);
      test_vois_beside(folder);
      test_user_errors(folder);
      test_msh_input(folder);
      test_geo_input(folder);
    }
  catch (const std::exception &e)
    {
      std::cout << "  FAIL  unexpected exception: " << e.what() << std::endl;
      ++failures;
    }
  if (failures == 0)
    fs::remove_all(folder);
  else
    std::cout << "files kept in " << folder << std::endl;
  std::cout << (failures == 0 ? "all meshing tests passed" : std::to_string(failures) + " meshing test(s) FAILED")
            << std::endl;
  return failures == 0 ? 0 : 1;
}
