// The meshing stage's driver: validates the inputs, loads the geometry into gmsh once, meshes every
// scenario whose cached mesh is out of date, and builds the display surface.
#include "scene_mesher.h"
#include "shared_meshes.h"

#include "gmsh_tools.h"
#include "mesher_parts.h"
#include "ribbed_panel_geometry.h"

#include <mrt/atomic_file.h>

#include <gmsh.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <queue>
#include <set>
#include <sstream>
#include <unordered_map>

namespace modal_haptics::meshing
{
  namespace fs = std::filesystem;
  using namespace detail;

  namespace
  {
    // Bump when anything in how meshes are made or written changes: every cached mesh is then redone.
    constexpr const char *mesh_format_version = "modal-haptics meshing 1";
    constexpr const char *log_prefix          = "[meshing] ";

    // The cores this process may run on (its affinity: a Slurm task's, a taskset's), at least 1.
    int cores_we_may_use()
    {
      cpu_set_t cores;
      CPU_ZERO(&cores);
      return sched_getaffinity(0, sizeof(cores), &cores) == 0 ? std::max(1, CPU_COUNT(&cores)) : 1;
    }

    // Measured on the ribbed panel (gmsh 4.8.4), where a thin rib wall is coarser than thick:
    // - 3D Delaunay (1) leaves slivers of SICN ~1e-4 between a rib's two faces in the fine VOI
    //   that its optimizer cannot remove, three attempts in a row; HXT (10) does not.
    // - HXT after MeshAdapt surface meshes (2D algorithm 1) corrupted the heap inside gmsh's
    //   hxtMeshDelete in 2 of 6 runs of tests/meshing; after Frontal-Delaunay (6) 0 of 10 and
    //   every precompute run. Frontal-Delaunay's mirror-identical meshes on a rib's two faces make
    //   HXT leave, rarely, one flat tet between them: the quality check catches it and the mesh is
    //   made again (gmsh is not deterministic, the next attempt differs).
    constexpr int algorithm_3d        = 10;
    constexpr int algorithm_2d        = 6;
    constexpr int max_volume_attempts = 3;


    // ---------------------------------------------------------------------------------------------
    // The mesher
    // ---------------------------------------------------------------------------------------------

    double seconds_since(const std::chrono::steady_clock::time_point start)
    {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    class SceneMesher
    {
    public:
      SceneMesher(const MeshingSettings &settings, const std::vector<VolumeOfInterest> &vois,
                  const std::string &output_directory, const bool verbose, const bool reuse_only)
        : settings(settings), vois(vois), directory(output_directory), verbose(verbose), reuse_only(reuse_only),
          kind(input_kind(settings.geometry))
      {}

      // The settings, the geometry file (or the built-in panel's dimensions) and the VOIs, before
      // anything is loaded or meshed.
      void check_inputs() const
      {
        check_settings(settings);
        if (kind != InputKind::builtin_panel)
          require_readable(settings.geometry, "geometry file");
        else
          check_ribbed_panel(settings.ribbed_panel);
        check_volumes_of_interest(vois, settings, kind);
      }

      SceneMeshes run()
      {
        check_inputs();
        create_output_directory();
        inputs = common_inputs();

        SceneMeshes meshes;
        VoiQueue    queue;
        start_vois_beside(queue);
        meshes.scenarios.push_back(kind == InputKind::msh ? copy_global_mesh() : mesh_scenario(nullptr));
        meshes.display_surface = display_surface();
        queue.mesh_remaining(*this);
        queue.wait_for_children();
        for (std::size_t i = 0; i < vois.size(); ++i)
          meshes.scenarios.push_back(mesh_scenario(&vois[i], queue.taken_by(i)));
        return meshes;
      }

      // Each mesh of 'source' made from the inputs this scene's needs, copied here with its key
      // unless this folder's is up to date: run() then reuses it.
      unsigned int adopt_meshes_of(const std::string &source)
      {
        check_inputs();
        create_output_directory();
        inputs = common_inputs();
        std::vector<std::pair<std::string, std::string>> wanted{{"mesh_global", scenario_key(nullptr)},
                                                                {"display_surface", key_of(display_surface_inputs())}};
        for (const auto &voi : vois)
          wanted.emplace_back("mesh_" + voi.name, scenario_key(&voi));
        unsigned int adopted = 0;
        for (const auto &[name, key] : wanted)
          adopted += adopt(source, name, key);
        return adopted;
      }

      GeometryReport inspect(const std::vector<std::pair<int, std::string>> &named_groups,
                             const std::vector<RegionSelection> &regions, const double length_unit)
      {
        check_inputs();
        GeometryReport report;
        if (kind == InputKind::cad)
          report.unit = declared_length_unit(settings.geometry);
        if (report.unit.metres > 0. && std::abs(length_unit / report.unit.metres - 1.) > 1e-9)
          {
            std::ostringstream message;
            message << "geometry file '" << settings.geometry << "' declares its length unit as " << report.unit.name
                    << " (" << report.unit.metres << " m), but 'Geometry/Length unit' = " << length_unit
                    << " m: set 'Length unit' to " << report.unit.metres
                    << " and give every length of the .prm file in " << report.unit.name << "s";
            throw MeshingError(message.str());
          }
        if (kind == InputKind::msh)
          inspect_mesh_file(report);
        else
          call_gmsh("loading geometry '" + settings.geometry + "'", [&] {
            load_model();
            const auto box = bounding_box();
            report.lower   = box[0];
            report.upper   = box[1];
            report.volume  = part_volume();
            report.clamp_boxes = clamp_box_reports;
            for (const auto &voi : vois)
              {
                check_against_bounding_box(voi);
                report.volumes_of_interest.push_back(inspect_voi(voi));
              }
            for (const auto &region : regions)
              report.regions.push_back(inspect_region(region, settings.geometry));
          });
        for (const auto &[dim, name] : empty_groups)
          report.empty_groups.push_back(empty_group_words(dim, name));
        for (const auto &[dim, name] : named_groups)
          {
            refuse_if_empty(dim, name);
            report.named_groups.push_back(inspect_group(kind, settings.geometry, dim, name));
          }
        return report;
      }

    private:
      const MeshingSettings                &settings;
      const std::vector<VolumeOfInterest> &vois;
      const std::string                     directory;
      const bool                            verbose;
      const bool                            reuse_only;     // a mesh not in the cache is an error
      const InputKind                       kind;
      std::string                           inputs;         // what every mesh of the scene depends on
      bool                                  model_loaded = false;
      std::vector<std::pair<int, std::string>> empty_groups; // named in a .geo, holding nothing
      std::vector<int>                      field_tags;     // the size fields currently defined
      std::vector<SelectionReport>          clamp_box_reports; // what each clamp box caught

      std::string path(const std::string &file) const { return (fs::path(directory) / file).string(); }

      std::string context(const std::string &scenario) const
      {
        return "scenario '" + scenario + "' of geometry '" + settings.geometry + "'";
      }

      void create_output_directory() const
      {
        std::error_code error;
        fs::create_directories(directory, error);
        if (error || !fs::is_directory(directory))
          throw MeshingError("cannot create the output folder '" + directory + "'");
      }

      std::string common_inputs() const
      {
        std::ostringstream out;
        out << std::setprecision(17) << mesh_format_version << "; gmsh " << GMSH_API_VERSION << '/' << gmsh_version()
            << "; algorithms " << algorithm_2d << '/' << algorithm_3d << "; coarse " << settings.coarse_size
            << "; geometry ";
        if (kind == InputKind::builtin_panel)
          out << describe_ribbed_panel(settings.ribbed_panel);
        else
          out << lower_case(fs::path(settings.geometry).extension().string()) << " content "
              << file_content_hash(settings.geometry);
        if (kind == InputKind::cad)
          out << " read in unit '" << declared_length_unit(settings.geometry).occ_code << "'";
        if (kind == InputKind::cad)
          for (const auto &box : settings.clamp_boxes)
            out << " clamp " << describe_point(box[0]) << describe_point(box[1]);
        return out.str();
      }

      void say(const std::string &line) const
      {
        if (verbose)
          std::cout << log_prefix << line << std::endl;
      }

      void report(const std::string &name, const MeshStatistics &s) const
      {
        std::ostringstream line;
        line << std::fixed << std::setprecision(3) << name << ": " << s.n_nodes << " nodes, " << s.n_tets
             << " tets, quality min " << s.min_quality << " mean " << s.mean_quality << ", "
             << std::setprecision(1) << s.seconds << " s" << (s.reused ? " (reused)" : "");
        say(line.str());
      }

      // Returns true (and the statistics) when the key file beside a mesh matches 'key'.
      static bool cached(const std::string &msh, const std::string &key_file, const std::string &key,
                         MeshStatistics &statistics)
      {
        KeyFile content;
        if (!fs::exists(msh) || !read_key_file(key_file, content) || content.key != key)
          return false;
        statistics        = content.statistics;
        statistics.reused = true;
        return true;
      }

      // A volume mesh in the cache that is up to date and still meets the quality bound.
      bool cached_volume_mesh(const std::string &msh, const std::string &key_file, const std::string &key,
                              MeshStatistics &statistics) const
      {
        return cached(msh, key_file, key, statistics) && statistics.min_quality > settings.min_quality;
      }

      // NAME.msh and NAME.key of 'source' copied here when the key there is 'key' and here is not.
      // The mesh goes first and the key last: a key vouches only for a mesh that is complete.
      bool adopt(const std::string &source, const std::string &name, const std::string &key) const
      {
        const fs::path from = fs::path(source) / name;
        MeshStatistics ignored_statistics;
        std::error_code ignored;
        if (fs::equivalent(source, directory, ignored) ||
            cached(path(name + ".msh"), path(name + ".key"), key, ignored_statistics) ||
            !cached(from.string() + ".msh", from.string() + ".key", key, ignored_statistics))
          return false;
        fs::remove(path(name + ".key"), ignored);
        for (const char *extension : {".msh", ".key"})
          {
            std::string error;
            if (!mrt::copy_file_atomically(from.string() + extension, path(name + extension), error))
              throw MeshingError(error);
          }
        say(name + ": taken from '" + source + "' (the same inputs)");
        return true;
      }

      // With reuse_only, a mesh that would have to be made is an error naming it.
      void require_meshing_allowed(const std::string &msh) const
      {
        if (reuse_only)
          throw MeshingError("'" + msh + "' is missing or was made from other inputs, and this run only reuses "
                             "meshes");
      }

      static ScenarioMesh scenario_result(const std::string &name, const std::string &msh, const std::string &key,
                                          const MeshStatistics &s)
      {
        ScenarioMesh mesh;
        mesh.name       = name;
        mesh.msh_file   = msh;
        mesh.cache_key  = key;
        mesh.statistics = s;
        auto names      = read_physical_names(msh);
        mesh.physical_surfaces = names[2];
        mesh.physical_volumes  = names[3];
        return mesh;
      }

      // --- inspecting the geometry without meshing ---------------------------------------------------

      // A .msh input: its bounding box and volume from its tets, its groups from $PhysicalNames.
      void inspect_mesh_file(GeometryReport &report)
      {
        PlainMesh mesh;
        call_gmsh("reading mesh file '" + settings.geometry + "'", [&] {
          gmsh::clear();
          gmsh::open(settings.geometry);
          mesh = read_current_mesh(true, false);
        });
        model_loaded = false;
        report.lower = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                        std::numeric_limits<double>::max()};
        report.upper = {-report.lower[0], -report.lower[1], -report.lower[2]};
        for (const auto &p : mesh.nodes)
          for (int i = 0; i < 3; ++i)
            {
              report.lower[i] = std::min(report.lower[i], p[i]);
              report.upper[i] = std::max(report.upper[i], p[i]);
            }
        for (const auto &t : mesh.tets)
          {
            const auto &a = mesh.nodes[t[0]], &b = mesh.nodes[t[1]], &c = mesh.nodes[t[2]], &d = mesh.nodes[t[3]];
            const Point3 u{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v{c[0] - a[0], c[1] - a[1], c[2] - a[2]},
              w{d[0] - a[0], d[1] - a[1], d[2] - a[2]};
            report.volume += std::abs(u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                                      u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.;
          }
      }

      // The boundary faces whose bounding box meets a VOI's box (a ball's bounding box): a VOI that
      // meets none is refused, naming the nearest face and its distance.
      SelectionReport inspect_voi(const VolumeOfInterest &voi) const
      {
        std::array<Point3, 2> region;
        for (int i = 0; i < 3; ++i)
          {
            const bool box = voi.shape == VolumeOfInterest::Shape::box;
            region[0][i]   = box ? voi.box_lower[i] : voi.ball_centre[i] - voi.ball_radius;
            region[1][i]   = box ? voi.box_upper[i] : voi.ball_centre[i] + voi.ball_radius;
          }
        std::string why;
        auto caught = faces_meeting("VOI '" + voi.name + "' (" + describe_region(voi) + ")",
                                    [&](const std::array<Point3, 2> &f) { return box_gap(region, f); }, why);
        if (caught.n_faces == 0)
          throw MeshingError(not_intersecting_message(voi, why));
        return caught;
      }

      // A selection may not name a group that the file declares empty: it would select nothing.
      void refuse_if_empty(const int dim, const std::string &name) const
      {
        for (const auto &empty : empty_groups)
          if (empty == std::make_pair(dim, name))
            throw MeshingError("Group '" + name + "' ('Geometry/Supports' or 'Clamp groups') of geometry file '" +
                               settings.geometry + "': " + empty_group_words(dim, name) +
                               "; fill the group in the file or select another group");
      }

      // --- the gmsh model -------------------------------------------------------------------------

      void load_model()
      {
        if (model_loaded)
          return;
        call_gmsh("loading geometry '" + settings.geometry + "'", [this] {
          gmsh::clear();
          field_tags.clear();
          if (kind == InputKind::builtin_panel)
            {
              gmsh::model::add("ribbed_panel");
              build_ribbed_panel(settings.ribbed_panel);
            }
          else if (kind == InputKind::cad)
            load_cad();
          else
            load_geo();
        });
        model_loaded = true;
      }

      void load_cad()
      {
        gmsh::model::add(fs::path(settings.geometry).stem().string());
        // In the file's declared unit, not OpenCASCADE's default millimetres ("" keeps the default
        // for a file that declares none, and for BREP).
        gmsh::option::setString("Geometry.OCCTargetUnit", declared_length_unit(settings.geometry).occ_code);
        DimTags shapes;
        gmsh::model::occ::importShapes(settings.geometry, shapes);
        DimTags volumes;
        for (const auto &s : shapes)
          if (s.first == 3)
            volumes.push_back(s);
        if (volumes.empty())
          throw MeshingError("geometry file '" + settings.geometry + "' holds no solid");
        if (volumes.size() > 1) // several touching solids must become one conforming part
          {
            DimTags              fused;
            std::vector<DimTags> history;
            gmsh::model::occ::fuse({volumes.front()}, {volumes.begin() + 1, volumes.end()}, fused, history);
          }
        gmsh::model::occ::synchronize();
        add_clamp_from_boxes();
        complete_physical_groups();
      }

      // Each box's boundary faces form the surface "clamp"; a box that catches none is refused,
      // naming the face it came nearest to. The tolerance is relative to the part's size, plus
      // OpenCASCADE's padding of bounding boxes, so a box at a face's exact coordinates catches it.
      void add_clamp_from_boxes()
      {
        clamp_box_reports.clear();
        const std::vector<int> boundary = boundary_faces();
        const auto             part     = bounding_box();
        double                 diagonal = 0.;
        for (int i = 0; i < 3; ++i)
          diagonal += std::pow(part[1][i] - part[0][i], 2);
        const double  tolerance = 1e-5 * std::sqrt(diagonal) + 2e-7;
        std::set<int> clamp;
        for (std::size_t b = 0; b < settings.clamp_boxes.size(); ++b)
          {
            std::array<Point3, 2> box;
            for (int i = 0; i < 3; ++i)
              {
                box[0][i] = std::min(settings.clamp_boxes[b][0][i], settings.clamp_boxes[b][1][i]);
                box[1][i] = std::max(settings.clamp_boxes[b][0][i], settings.clamp_boxes[b][1][i]);
              }
            SelectionReport caught;
            caught.name = "'Geometry/Clamp boxes' entry " + std::to_string(b + 1) + " (" + readable_point(box[0]) +
                          "-" + readable_point(box[1]) + ")";
            for (const int face : entities_inside_box(2, box[0], box[1], tolerance))
              if (std::binary_search(boundary.begin(), boundary.end(), face))
                {
                  clamp.insert(face);
                  ++caught.n_faces;
                  caught.area += face_area(face);
                }
            if (caught.n_faces == 0)
              throw MeshingError(nothing_caught_message(caught.name, box, boundary, tolerance));
            clamp_box_reports.push_back(caught);
          }
        add_named_group(2, {clamp.begin(), clamp.end()}, "clamp", 1);
      }

      std::string nothing_caught_message(const std::string &name, const std::array<Point3, 2> &box,
                                         const std::vector<int> &boundary, const double tolerance) const
      {
        int    nearest = 0;
        double growth  = std::numeric_limits<double>::max();
        for (const int face : boundary)
          if (const double g = growth_to_catch(box, bounding_box(2, face)); g < growth)
            {
              growth  = g;
              nearest = face;
            }
        std::ostringstream message;
        message << name << " of geometry '" << settings.geometry
                << "' catches no boundary face (a face is caught when its bounding box lies inside the box, "
                   "within "
                << tolerance << ")";
        if (nearest > 0)
          {
            const auto face = bounding_box(2, nearest);
            message << "; the nearest is face " << nearest << " with bounding box " << readable_point(face[0]) << "-"
                    << readable_point(face[1]) << ", caught if the box grew by " << growth;
          }
        message << " (units of the geometry)";
        return message.str();
      }

      void load_geo()
      {
        gmsh::open(settings.geometry);
        DimTags volumes;
        gmsh::model::getEntities(volumes, 3);
        if (volumes.empty())
          throw MeshingError("geometry file '" + settings.geometry + "' defines no volume");
        empty_groups = require_named_groups("geometry file '" + settings.geometry + "'");
        complete_physical_groups();
      }

      void remove_size_fields()
      {
        for (const int tag : field_tags)
          gmsh::model::mesh::field::remove(tag);
        field_tags.clear();
      }

      int add_field(const std::string &type)
      {
        field_tags.push_back(gmsh::model::mesh::field::add(type));
        return field_tags.back();
      }

      // The VOI's size: fine inside, growing linearly to the coarse size over 'transition' outside.
      int add_voi_field(const VolumeOfInterest &voi)
      {
        namespace field = gmsh::model::mesh::field;
        const bool box  = voi.shape == VolumeOfInterest::Shape::box;
        const int  tag  = add_field(box ? "Box" : "Ball");
        field::setNumber(tag, "VIn", voi.fine_size);
        field::setNumber(tag, "VOut", settings.coarse_size);
        field::setNumber(tag, "Thickness", voi.transition);
        if (box)
          {
            const char *lower[] = {"XMin", "YMin", "ZMin"}, *upper[] = {"XMax", "YMax", "ZMax"};
            for (int i = 0; i < 3; ++i)
              {
                field::setNumber(tag, lower[i], voi.box_lower[i]);
                field::setNumber(tag, upper[i], voi.box_upper[i]);
              }
          }
        else
          {
            const char *centre[] = {"XCenter", "YCenter", "ZCenter"};
            for (int i = 0; i < 3; ++i)
              field::setNumber(tag, centre[i], voi.ball_centre[i]);
            field::setNumber(tag, "Radius", voi.ball_radius);
          }
        return tag;
      }

      // Only the background field decides the size (no size from points, curvature or boundary),
      // so that a mesh depends on the scenario's settings only.
      void set_size_field(const std::vector<const VolumeOfInterest *> &graded)
      {
        namespace field = gmsh::model::mesh::field;
        remove_size_fields();
        int background = 0;
        if (graded.empty())
          {
            background = add_field("MathEval"); // gmsh 4.8 has no "Constant" field
            std::ostringstream size;
            size << std::setprecision(17) << settings.coarse_size;
            field::setString(background, "F", size.str());
          }
        else
          {
            std::vector<double> tags;
            for (const auto *voi : graded)
              tags.push_back(add_voi_field(*voi));
            background = tags.front();
            if (tags.size() > 1)
              {
                background = add_field("Min");
                field::setNumbers(background, "FieldsList", tags);
              }
          }
        field::setAsBackgroundMesh(background);
      }

      void set_mesh_options() const
      {
        namespace option = gmsh::option;
        option::setNumber("Mesh.MeshSizeExtendFromBoundary", 0);
        option::setNumber("Mesh.MeshSizeFromPoints", 0);
        option::setNumber("Mesh.MeshSizeFromCurvature", 0);
        option::setNumber("Mesh.MeshSizeMin", 0.);
        option::setNumber("Mesh.MeshSizeMax", settings.coarse_size);
        option::setNumber("Mesh.ElementOrder", 1);
        option::setNumber("Mesh.Algorithm", algorithm_2d);
        option::setNumber("Mesh.Algorithm3D", algorithm_3d);
        option::setNumber("Mesh.Optimize", 1);
        option::setNumber("General.NumThreads", settings.mesh_threads > 0 ? settings.mesh_threads : cores_we_may_use());
      }

      void generate(const int dimension, const std::vector<const VolumeOfInterest *> &graded)
      {
        set_mesh_options();
        set_size_field(graded);
        gmsh::model::mesh::clear();
        gmsh::model::mesh::generate(dimension);
      }

      // Fails early, before any meshing time is spent, when the VOI lies outside the part's box.
      void check_against_bounding_box(const VolumeOfInterest &voi) const
      {
        double lower[3], upper[3];
        gmsh::model::getBoundingBox(-1, -1, lower[0], lower[1], lower[2], upper[0], upper[1], upper[2]);
        for (int i = 0; i < 3; ++i)
          {
            const double voi_lower = voi.shape == VolumeOfInterest::Shape::box ? voi.box_lower[i]
                                                                               : voi.ball_centre[i] - voi.ball_radius;
            const double voi_upper = voi.shape == VolumeOfInterest::Shape::box ? voi.box_upper[i]
                                                                               : voi.ball_centre[i] + voi.ball_radius;
            if (voi_upper < lower[i] || voi_lower > upper[i])
              throw MeshingError(not_intersecting_message(
                voi, "the part's bounding box is " + readable_point({lower[0], lower[1], lower[2]}) + "-" +
                       readable_point({upper[0], upper[1], upper[2]})));
          }
      }

      // --- the scenarios --------------------------------------------------------------------------

      // Who took a VOI from the queue of start_vois_beside (and made its mesh in this run).
      enum class TakenBy
      {
        nobody,
        this_process,
        child
      };

      // A mesh taken from the queue (taken_by not nobody) was made and reported then: read from the
      // cache, it counts as made, not reused, and is not reported again.
      ScenarioMesh mesh_scenario(const VolumeOfInterest *voi, const TakenBy taken_by = TakenBy::nobody)
      {
        const std::string name = voi ? voi->name : "global";
        const std::string msh = path("mesh_" + name + ".msh"), key_file = path("mesh_" + name + ".key");
        const std::string key = scenario_key(voi);

        MeshStatistics statistics;
        if (cached_volume_mesh(msh, key_file, key, statistics))
          {
            if (taken_by != TakenBy::nobody)
              statistics.reused = false, statistics.made_in_child_process = taken_by == TakenBy::child;
            else
              report(name, statistics);
            return scenario_result(name, msh, key, statistics);
          }
        require_meshing_allowed(msh);
        // The old key must go first: a crash after the new mesh is in place must not leave a key
        // that vouches for it with other inputs.
        std::error_code ignored;
        fs::remove(key_file, ignored);

        const auto start = std::chrono::steady_clock::now();
        load_model();
        call_gmsh(context(name), [&] {
          if (voi)
            check_against_bounding_box(*voi);
          statistics = generate_volume_mesh(name, voi);
          write_mesh_atomically(msh);
        });
        statistics.seconds = seconds_since(start);
        write_key_file(key_file, scenario_inputs(voi), key, statistics);
        report(name, statistics);
        return scenario_result(name, msh, key, statistics);
      }

      std::string scenario_inputs(const VolumeOfInterest *voi) const
      {
        return inputs + "; " + (voi ? describe_voi(*voi) : "global");
      }
      std::string scenario_key(const VolumeOfInterest *voi) const { return key_of(scenario_inputs(voi)); }

      // True when the VOI's mesh in the folder is up to date (nothing to make).
      bool voi_cached(const VolumeOfInterest &voi) const
      {
        MeshStatistics statistics;
        return cached_volume_mesh(path("mesh_" + voi.name + ".msh"), path("mesh_" + voi.name + ".key"),
                                  scenario_key(&voi), statistics);
      }

      // The VOIs' volume meshes are independent of each other and of the global one, and gmsh meshes
      // one at a time per process (its state is global; its own threads make different meshes at
      // every run, Meshing/Threads): with more than one core, child processes (fork, after the
      // geometry is loaded, so that they inherit it) take the VOIs to mesh from a queue in shared
      // memory while this process meshes the global scenario and the display surface, then takes
      // the rest too. A child writes its mesh into the cache and exits; this process then reads it
      // from there. A child that fails leaves its VOI to this process, which meshes it again and
      // reports the error itself. What it saves: docs/performance.md, "The VOIs meshed in child processes".
      class VoiQueue
      {
      public:
        VoiQueue() = default;
        VoiQueue(const VoiQueue &) = delete;
        ~VoiQueue()
        {
          wait_for_children();
          if (shared != nullptr)
            munmap(shared, bytes());
        }

        // Queues the VOIs in 'pending' (indices) and starts up to 'n_children' processes on them.
        void start(SceneMesher &mesher, std::vector<std::size_t> to_mesh, const int n_children)
        {
          pending = std::move(to_mesh);
          n       = mesher.vois.size();
          void *memory = mmap(nullptr, bytes(), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
          if (memory == MAP_FAILED)
            return; // no queue: this process meshes every VOI, as without children
          shared = new (memory) std::atomic<int>[1 + n];
          for (std::size_t i = 0; i <= n; ++i)
            shared[i].store(0);
          std::cout.flush();
          for (int c = 0; c < n_children; ++c)
            {
              const pid_t pid = fork();
              if (pid == 0)
                {
                  int status = 0;
                  try
                    {
                      mesh_remaining(mesher, TakenBy::child);
                    }
                  catch (...)
                    {
                      status = 1;
                    }
                  std::cout.flush();
                  std::_Exit(status); // no exit handlers: they are the parent's (MPI, gmsh, timers)
                }
              if (pid > 0)
                children.push_back(pid);
            }
        }

        // Meshes queued VOIs until none is left, marking each as made in this run (and by whom).
        void mesh_remaining(SceneMesher &mesher, const TakenBy taken_by = TakenBy::this_process)
        {
          if (shared == nullptr)
            return;
          for (int k; (k = shared[0].fetch_add(1)) < int(pending.size());)
            {
              const std::size_t i = pending[k];
              shared[1 + i].store(int(taken_by));
              mesher.mesh_scenario(&mesher.vois[i]);
            }
        }

        void wait_for_children()
        {
          // A child's exit status is not needed: what it made is in the cache, or made again here.
          for (const pid_t pid : children)
            while (waitpid(pid, nullptr, 0) < 0 && errno == EINTR)
              {
              }
          children.clear();
        }

        TakenBy taken_by(const std::size_t i) const
        {
          return shared != nullptr ? TakenBy(shared[1 + i].load()) : TakenBy::nobody;
        }

      private:
        std::size_t bytes() const { return sizeof(std::atomic<int>) * (1 + n); }

        std::atomic<int>        *shared = nullptr; // [0]: the next queue position; [1 + i]: who took VOI i (TakenBy)
        std::size_t              n      = 0;
        std::vector<pid_t>       children;
        std::vector<std::size_t> pending;
      };

      // Only where asked (MeshingSettings::mesh_vois_beside), with gmsh on one thread and more than
      // one core, and when a VOI's mesh is to be made.
      void start_vois_beside(VoiQueue &queue)
      {
        const int cores = cores_we_may_use();
        if (!settings.mesh_vois_beside || settings.mesh_threads != 1 || cores < 2 || reuse_only ||
            kind == InputKind::msh)
          return;
        std::vector<std::size_t> to_mesh;
        for (std::size_t i = 0; i < vois.size(); ++i)
          if (!voi_cached(vois[i]))
            to_mesh.push_back(i);
        if (to_mesh.empty())
          return;
        load_model();
        queue.start(*this, to_mesh, std::min<int>(cores - 1, to_mesh.size()));
      }

      // Meshes the volume graded towards 'voi' (coarse everywhere when null) until its quality is
      // acceptable; checks that the VOI holds mesh nodes.
      MeshStatistics generate_volume_mesh(const std::string &name, const VolumeOfInterest *voi)
      {
        const auto graded = voi ? std::vector<const VolumeOfInterest *>{voi} : std::vector<const VolumeOfInterest *>{};
        for (int attempt = 1;; ++attempt)
          {
            gmsh::option::setNumber("Mesh.RandomSeed", attempt);
            generate(3, graded);
            const PlainMesh mesh = read_current_mesh(true, false);
            if (voi && !any_node_inside(mesh, *voi))
              throw MeshingError(not_intersecting_message(*voi, "no mesh node lies inside it"));
            if (voi)
              say("VOI '" + voi->name + "' (" + describe_region(*voi) + "): " +
                  std::to_string(std::count_if(mesh.nodes.begin(), mesh.nodes.end(),
                                               [voi](const Point3 &p) { return voi->contains(p); })) +
                  " of " + std::to_string(mesh.nodes.size()) + " mesh vertices inside");
            try
              {
                return tet_statistics(mesh, settings.min_quality, context(name));
              }
            catch (const MeshingError &bad_quality)
              {
                if (attempt == max_volume_attempts)
                  throw;
                say(std::string(bad_quality.what()) + "; meshing again");
              }
          }
      }

      // A .msh input is the global mesh as it is: copied beside the others, quality checked.
      ScenarioMesh copy_global_mesh()
      {
        const std::string msh = path("mesh_global.msh"), key_file = path("mesh_global.key");
        const std::string key = scenario_key(nullptr);
        MeshStatistics    statistics;
        if (cached_volume_mesh(msh, key_file, key, statistics))
          {
            report("global", statistics);
            return scenario_result("global", msh, key, statistics);
          }
        require_meshing_allowed(msh);
        std::error_code ignored;
        fs::remove(key_file, ignored);
        const auto start = std::chrono::steady_clock::now();
        statistics       = check_mesh_quality(settings.geometry, settings.min_quality);
        if (!fs::equivalent(settings.geometry, msh, ignored))
          {
            std::string error;
            if (!mrt::copy_file_atomically(settings.geometry, msh, error))
              throw MeshingError(error);
          }
        statistics.seconds = seconds_since(start);
        write_key_file(key_file, scenario_inputs(nullptr), key, statistics);
        report("global", statistics);
        return scenario_result("global", msh, key, statistics);
      }

      // --- the display surface --------------------------------------------------------------------

      DisplaySurface display_surface()
      {
        const std::string msh = path("display_surface.msh"), key_file = path("display_surface.key");
        const std::string surface_inputs = display_surface_inputs();
        const std::string key            = key_of(surface_inputs);

        MeshStatistics statistics;
        DisplaySurface surface;
        const auto     start = std::chrono::steady_clock::now();
        if (cached(msh, key_file, key, statistics))
          surface = read_display_surface(msh);
        else
          {
            require_meshing_allowed(msh);
            std::error_code ignored;
            fs::remove(key_file, ignored);
            call_gmsh("writing the display surface '" + msh + "'",
                      [&] { write_display_surface(make_display_surface(), msh); });
            model_loaded = false; // writing replaced the model
            // What is returned is what the file holds (the file's coordinates are rounded), so a
            // later run that reuses the file gets exactly the same surface.
            surface = read_display_surface(msh);
          }
        surface.msh_file           = msh;
        surface.cache_key          = key;
        surface.statistics         = triangle_statistics(surface);
        surface.statistics.reused  = statistics.reused;
        surface.statistics.seconds = statistics.reused ? 0. : seconds_since(start);
        if (!statistics.reused)
          write_key_file(key_file, surface_inputs, key, surface.statistics);
        say("display surface: " + std::to_string(surface.vertices.size()) + " vertices, " +
            std::to_string(surface.triangles.size()) + " triangles" + (statistics.reused ? " (reused)" : ""));
        return surface;
      }

      std::string display_surface_inputs() const
      {
        std::string surface_inputs = inputs + "; display surface";
        for (const auto &voi : vois)
          surface_inputs += "; " + describe_voi(voi);
        return surface_inputs;
      }

      DisplaySurface make_display_surface()
      {
        PlainMesh mesh;
        if (kind == InputKind::msh)
          call_gmsh("display surface of '" + settings.geometry + "'", [&] {
            gmsh::clear();
            gmsh::open(settings.geometry);
            mesh = boundary_of_tets(read_current_mesh(true, false));
            model_loaded = false;
          });
        else
          {
            load_model();
            call_gmsh(context("display surface"), [&] {
              std::vector<const VolumeOfInterest *> graded;
              for (const auto &voi : vois)
                graded.push_back(&voi);
              generate(2, graded);
              mesh = read_current_mesh(false, true);
            });
          }
        if (mesh.triangles.empty())
          throw MeshingError("geometry '" + settings.geometry + "': the display surface has no triangle");
        return display_surface_from(mesh);
      }

      DisplaySurface read_display_surface(const std::string &msh)
      {
        PlainMesh mesh;
        call_gmsh("reading the display surface '" + msh + "'", [&] {
          gmsh::clear();
          gmsh::open(msh);
          mesh = read_current_mesh(false, true);
        });
        model_loaded = false;
        DisplaySurface surface;
        surface.vertices  = std::move(mesh.nodes);
        surface.triangles = std::move(mesh.triangles);
        return surface;
      }
    };
  } // namespace

  bool VolumeOfInterest::contains(const Point3 &p, const double tolerance) const
  {
    if (shape == Shape::ball)
      {
        const double dx = p[0] - ball_centre[0], dy = p[1] - ball_centre[1], dz = p[2] - ball_centre[2];
        return std::sqrt(dx * dx + dy * dy + dz * dz) <= ball_radius + tolerance;
      }
    for (int i = 0; i < 3; ++i)
      if (p[i] < box_lower[i] - tolerance || p[i] > box_upper[i] + tolerance)
        return false;
    return true;
  }

  SceneMeshes mesh_scene(const MeshingSettings &settings, const std::vector<VolumeOfInterest> &volumes_of_interest,
                         const std::string &output_directory, const bool verbose, const bool reuse_only)
  {
    // Plain input errors are reported before gmsh is even started.
    SceneMesher mesher(settings, volumes_of_interest, output_directory, verbose, reuse_only);
    GmshSession session(verbose);
    return mesher.run();
  }

  unsigned int adopt_meshes(const MeshingSettings &settings, const std::vector<VolumeOfInterest> &volumes_of_interest,
                            const std::string &source_directory, const std::string &output_directory,
                            const bool verbose)
  {
    SceneMesher mesher(settings, volumes_of_interest, output_directory, verbose, false);
    GmshSession session(false); // the keys name gmsh's version
    return mesher.adopt_meshes_of(source_directory);
  }

  GeometryReport inspect_geometry(const MeshingSettings &settings, const std::vector<VolumeOfInterest> &volumes_of_interest,
                                  const std::vector<std::pair<int, std::string>> &named_groups,
                                  const std::vector<RegionSelection> &regions, const double length_unit)
  {
    SceneMesher  mesher(settings, volumes_of_interest, "", false, true);
    GmshSession  session(false);
    return mesher.inspect(named_groups, regions, length_unit);
  }
} // namespace modal_haptics::meshing
