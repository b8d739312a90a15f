// The meshing stage's driver: validates the inputs, loads the geometry into gmsh once, meshes every
// scenario whose cached mesh is out of date, and builds the display surface.
#include "scene_mesher.h"

#include "gmsh_tools.h"
#include "ribbed_panel_geometry.h"

#include <gmsh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
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
    constexpr const char *builtin_panel       = "builtin:ribbed_panel";
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

    enum class InputKind { builtin_panel, cad, geo, msh };

    std::string lower_case(std::string text)
    {
      std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
      return text;
    }

    InputKind input_kind(const std::string &geometry)
    {
      if (geometry == builtin_panel)
        return InputKind::builtin_panel;
      if (geometry.rfind("builtin:", 0) == 0)
        throw MeshingError("unknown built-in geometry '" + geometry + "' (known: " + builtin_panel + ")");
      const std::string extension = lower_case(fs::path(geometry).extension().string());
      if (extension == ".step" || extension == ".stp" || extension == ".brep")
        return InputKind::cad;
      if (extension == ".geo")
        return InputKind::geo;
      if (extension == ".msh")
        return InputKind::msh;
      throw MeshingError("geometry '" + geometry + "': unknown kind (expected " + builtin_panel +
                         ", .step, .stp, .brep, .geo or .msh)");
    }

    // ---------------------------------------------------------------------------------------------
    // Hashing and the cache key files
    // ---------------------------------------------------------------------------------------------

    // FNV-1a, 64 bit: enough to tell whether the inputs of a mesh changed (not a security hash).
    std::uint64_t fnv1a(const char *data, const std::size_t size, std::uint64_t hash = 14695981039346656037ull)
    {
      for (std::size_t i = 0; i < size; ++i)
        {
          hash ^= static_cast<unsigned char>(data[i]);
          hash *= 1099511628211ull;
        }
      return hash;
    }

    std::string hex(const std::uint64_t value)
    {
      std::ostringstream out;
      out << std::hex << std::setw(16) << std::setfill('0') << value;
      return out.str();
    }

    void require_readable(const std::string &file, const std::string &what)
    {
      std::ifstream input(file, std::ios::binary);
      if (file.empty() || !input || fs::is_directory(file))
        throw MeshingError(what + " '" + file + "' does not exist or cannot be read");
    }

    std::string file_content_hash(const std::string &file)
    {
      std::ifstream input(file, std::ios::binary);
      if (!input)
        throw MeshingError("geometry file '" + file + "' does not exist or cannot be read");
      std::uint64_t     hash = 14695981039346656037ull;
      std::vector<char> buffer(1 << 16);
      while (input.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || input.gcount() > 0)
        hash = fnv1a(buffer.data(), static_cast<std::size_t>(input.gcount()), hash);
      return hex(hash);
    }

    std::string describe_point(const Point3 &p)
    {
      std::ostringstream out;
      out << std::setprecision(17) << '[' << p[0] << ',' << p[1] << ',' << p[2] << ']';
      return out.str();
    }

    // For messages: short numbers.
    std::string readable_point(const Point3 &p)
    {
      std::ostringstream out;
      out << std::setprecision(6) << '[' << p[0] << ", " << p[1] << ", " << p[2] << ']';
      return out.str();
    }

    std::string describe_voi(const VolumeOfInterest &voi)
    {
      std::ostringstream out;
      out << std::setprecision(17) << "voi " << voi.name;
      if (voi.shape == VolumeOfInterest::Shape::box)
        out << " box " << describe_point(voi.box_lower) << describe_point(voi.box_upper);
      else
        out << " ball " << describe_point(voi.ball_centre) << ' ' << voi.ball_radius;
      out << " fine " << voi.fine_size << " transition " << voi.transition;
      return out.str();
    }

    // A short, readable region for error messages.
    std::string describe_region(const VolumeOfInterest &voi)
    {
      std::ostringstream out;
      if (voi.shape == VolumeOfInterest::Shape::box)
        out << "box " << readable_point(voi.box_lower) << '-' << readable_point(voi.box_upper);
      else
        out << "ball centre " << readable_point(voi.ball_centre) << " radius " << std::setprecision(6)
            << voi.ball_radius;
      return out.str();
    }

    // What a cache key file holds: the hash of the inputs and the statistics of the mesh it made.
    struct KeyFile
    {
      std::string    key;
      MeshStatistics statistics;
    };

    bool read_key_file(const std::string &path, KeyFile &content)
    {
      std::ifstream input(path);
      std::string   word;
      if (!input)
        return false;
      MeshStatistics &s = content.statistics;
      while (input >> word)
        {
          if (word == "key") input >> content.key;
          else if (word == "n_nodes") input >> s.n_nodes;
          else if (word == "n_tets") input >> s.n_tets;
          else if (word == "min_quality") input >> s.min_quality;
          else if (word == "mean_quality") input >> s.mean_quality;
          else if (word == "max_quality") input >> s.max_quality;
          else std::getline(input, word); // comments and unknown lines
        }
      return !content.key.empty();
    }

    void write_text_atomically(const std::string &path, const std::string &text)
    {
      const std::string temporary = path + ".tmp";
      {
        std::ofstream output(temporary);
        output << text;
        if (!output)
          throw MeshingError("cannot write '" + temporary + "'");
      }
      if (std::rename(temporary.c_str(), path.c_str()) != 0)
        throw MeshingError("cannot rename '" + temporary + "' to '" + path + "'");
    }

    void write_key_file(const std::string &path, const std::string &inputs, const std::string &key,
                        const MeshStatistics &s)
    {
      std::ostringstream out;
      out << std::setprecision(17) << "# inputs: " << inputs << "\nkey " << key << "\nn_nodes " << s.n_nodes
          << "\nn_tets " << s.n_tets << "\nmin_quality " << s.min_quality << "\nmean_quality " << s.mean_quality
          << "\nmax_quality " << s.max_quality << '\n';
      write_text_atomically(path, out.str());
    }

    // ---------------------------------------------------------------------------------------------
    // Validation of the inputs
    // ---------------------------------------------------------------------------------------------

    void check_settings(const MeshingSettings &settings)
    {
      if (!(settings.coarse_size > 0.))
        throw MeshingError("coarse size must be > 0 (is " + std::to_string(settings.coarse_size) + ")");
      if (settings.mesh_threads < 1)
        throw MeshingError("mesh threads must be >= 1");
      if (!(settings.min_quality < 1.))
        throw MeshingError("minimum quality must be < 1 (1 is the regular tet)");
    }

    bool is_file_name_safe(const std::string &name)
    {
      return !name.empty() && std::all_of(name.begin(), name.end(), [](unsigned char c) {
        return std::isalnum(c) || c == '_' || c == '-' || c == '.';
      }) && name.front() != '.';
    }

    void check_volume_of_interest(const VolumeOfInterest &voi, const MeshingSettings &settings)
    {
      const std::string what = "VOI '" + voi.name + "'";
      if (!is_file_name_safe(voi.name) || voi.name == "global")
        throw MeshingError(what + ": a scenario name must be made of letters, digits, '_', '-', '.' and not be 'global'");
      if (!(voi.fine_size > 0.) || voi.fine_size > settings.coarse_size)
        throw MeshingError(what + ": fine size must be in (0, coarse size = " + std::to_string(settings.coarse_size) + "]");
      if (!(voi.transition >= 0.))
        throw MeshingError(what + ": transition must be >= 0");
      if (voi.shape == VolumeOfInterest::Shape::box)
        {
          for (int i = 0; i < 3; ++i)
            if (!(voi.box_lower[i] < voi.box_upper[i]))
              throw MeshingError(what + ": box lower corner must be below the upper corner in x, y and z (" +
                                 describe_region(voi) + ")");
        }
      else if (!(voi.ball_radius > 0.))
        throw MeshingError(what + ": ball radius must be > 0");
    }

    void check_volumes_of_interest(const std::vector<VolumeOfInterest> &vois, const MeshingSettings &settings,
                                   const InputKind kind)
    {
      std::set<std::string> names;
      for (const auto &voi : vois)
        {
          check_volume_of_interest(voi, settings);
          if (!names.insert(voi.name).second)
            throw MeshingError("two VOIs are named '" + voi.name + "'");
          if (kind == InputKind::msh)
            throw MeshingError("VOI '" + voi.name + "': cannot re-grade a .msh input ('" + settings.geometry +
                               "'); give the geometry as STEP/.geo to mesh scenarios");
        }
    }

    // ---------------------------------------------------------------------------------------------
    // Mesh checks
    // ---------------------------------------------------------------------------------------------

    Point3 centroid(const PlainMesh &mesh, const std::array<unsigned int, 4> &tet)
    {
      Point3 c{0., 0., 0.};
      for (const unsigned int v : tet)
        for (int i = 0; i < 3; ++i)
          c[i] += mesh.nodes[v][i] / 4.;
      return c;
    }

    // Quality statistics of the tets; throws naming the worst element when it is not acceptable.
    MeshStatistics tet_statistics(const PlainMesh &mesh, const double min_quality, const std::string &what)
    {
      if (mesh.tets.empty())
        throw MeshingError(what + ": the mesh has no tetrahedra");
      MeshStatistics s;
      s.n_nodes       = mesh.nodes.size();
      s.n_tets        = mesh.tets.size();
      s.min_quality   = std::numeric_limits<double>::max();
      s.max_quality   = -std::numeric_limits<double>::max();
      std::size_t worst = 0;
      double      sum   = 0.;
      for (std::size_t t = 0; t < mesh.tets.size(); ++t)
        {
          const auto  &v = mesh.tets[t];
          const double q = tet_sicn(mesh.nodes[v[0]], mesh.nodes[v[1]], mesh.nodes[v[2]], mesh.nodes[v[3]]);
          sum += q;
          s.max_quality = std::max(s.max_quality, q);
          if (q < s.min_quality)
            {
              s.min_quality = q;
              worst         = t;
            }
        }
      s.mean_quality = sum / double(mesh.tets.size());
      if (s.min_quality <= min_quality)
        {
          std::ostringstream message;
          message << what << ": tetrahedron " << mesh.tet_tags[worst] << " at " << readable_point(centroid(mesh, mesh.tets[worst]))
                  << " has quality (SICN) " << s.min_quality
                  << (s.min_quality <= 0. ? " (inverted or degenerate)" : "") << ", the minimum accepted is "
                  << min_quality;
          throw MeshingError(message.str());
        }
      return s;
    }

    bool any_node_inside(const PlainMesh &mesh, const VolumeOfInterest &voi)
    {
      return std::any_of(mesh.nodes.begin(), mesh.nodes.end(), [&voi](const Point3 &p) { return voi.contains(p); });
    }

    std::string not_intersecting_message(const VolumeOfInterest &voi, const std::string &why)
    {
      return "VOI '" + voi.name + "' (" + describe_region(voi) + ") does not intersect the part: " + why +
             "; move the VOI onto the part";
    }

    // ---------------------------------------------------------------------------------------------
    // The display surface: one conforming, outward-oriented triangulation of the whole boundary
    // ---------------------------------------------------------------------------------------------

    // Merges nodes with identical coordinates (entities meshed separately may duplicate them) and
    // drops the triangles that collapse.
    void merge_duplicate_vertices(DisplaySurface &surface)
    {
      std::map<Point3, unsigned int> index_of;
      std::vector<unsigned int>      new_index(surface.vertices.size());
      std::vector<Point3>            merged;
      for (std::size_t v = 0; v < surface.vertices.size(); ++v)
        {
          const auto inserted = index_of.emplace(surface.vertices[v], static_cast<unsigned int>(merged.size()));
          if (inserted.second)
            merged.push_back(surface.vertices[v]);
          new_index[v] = inserted.first->second;
        }
      std::vector<std::array<unsigned int, 3>> kept;
      for (const auto &t : surface.triangles)
        {
          const std::array<unsigned int, 3> n{new_index[t[0]], new_index[t[1]], new_index[t[2]]};
          if (n[0] != n[1] && n[1] != n[2] && n[0] != n[2])
            kept.push_back(n);
        }
      surface.vertices  = std::move(merged);
      surface.triangles = std::move(kept);
    }

    std::uint64_t edge_key(unsigned int a, unsigned int b)
    {
      if (a > b)
        std::swap(a, b);
      return (std::uint64_t(a) << 32) | b;
    }

    bool has_directed_edge(const std::array<unsigned int, 3> &t, const unsigned int a, const unsigned int b)
    {
      for (int i = 0; i < 3; ++i)
        if (t[i] == a && t[(i + 1) % 3] == b)
          return true;
      return false;
    }

    // Makes neighbouring triangles agree (a shared manifold edge is run through in opposite
    // directions) and returns the connected component of each triangle.
    std::vector<unsigned int> orient_consistently(std::vector<std::array<unsigned int, 3>> &triangles)
    {
      std::unordered_map<std::uint64_t, std::vector<unsigned int>> triangles_of_edge;
      for (unsigned int t = 0; t < triangles.size(); ++t)
        for (int i = 0; i < 3; ++i)
          triangles_of_edge[edge_key(triangles[t][i], triangles[t][(i + 1) % 3])].push_back(t);

      constexpr auto            unvisited = static_cast<unsigned int>(-1);
      std::vector<unsigned int> component(triangles.size(), unvisited);
      unsigned int              n_components = 0;
      for (unsigned int seed = 0; seed < triangles.size(); ++seed)
        {
          if (component[seed] != unvisited)
            continue;
          std::queue<unsigned int> front;
          component[seed] = n_components;
          front.push(seed);
          while (!front.empty())
            {
              const unsigned int t = front.front();
              front.pop();
              for (int i = 0; i < 3; ++i)
                {
                  const unsigned int a = triangles[t][i], b = triangles[t][(i + 1) % 3];
                  const auto        &sharing = triangles_of_edge[edge_key(a, b)];
                  if (sharing.size() != 2) // a boundary or non-manifold edge says nothing
                    continue;
                  const unsigned int n = sharing[0] == t ? sharing[1] : sharing[0];
                  if (component[n] != unvisited)
                    continue;
                  if (has_directed_edge(triangles[n], a, b))
                    std::swap(triangles[n][1], triangles[n][2]);
                  component[n] = n_components;
                  front.push(n);
                }
            }
          ++n_components;
        }
      return component;
    }

    // Turns every connected component outward: its enclosed volume, sum of centroid . (area normal)
    // (= 3 V by the divergence theorem), must be positive. Assumes the part has no inner voids.
    void orient_outward(DisplaySurface &surface)
    {
      const std::vector<unsigned int> component = orient_consistently(surface.triangles);
      const unsigned int n_components = component.empty() ? 0 : *std::max_element(component.begin(), component.end()) + 1;
      std::vector<double> signed_volume(n_components, 0.);
      for (std::size_t t = 0; t < surface.triangles.size(); ++t)
        {
          const Point3 &a = surface.vertices[surface.triangles[t][0]], &b = surface.vertices[surface.triangles[t][1]],
                       &c = surface.vertices[surface.triangles[t][2]];
          // a . (b x c) is 6 times the signed volume of the tet (origin, a, b, c).
          signed_volume[component[t]] += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                                         a[2] * (b[0] * c[1] - b[1] * c[0]);
        }
      for (std::size_t t = 0; t < surface.triangles.size(); ++t)
        if (signed_volume[component[t]] < 0.)
          std::swap(surface.triangles[t][1], surface.triangles[t][2]);
    }

    MeshStatistics triangle_statistics(const DisplaySurface &surface)
    {
      MeshStatistics s;
      s.n_nodes = surface.vertices.size();
      if (surface.triangles.empty())
        return s;
      s.min_quality = std::numeric_limits<double>::max();
      double sum    = 0.;
      for (const auto &t : surface.triangles)
        {
          const double q =
            triangle_shape_quality(surface.vertices[t[0]], surface.vertices[t[1]], surface.vertices[t[2]]);
          s.min_quality = std::min(s.min_quality, q);
          s.max_quality = std::max(s.max_quality, q);
          sum += q;
        }
      s.mean_quality = sum / double(surface.triangles.size());
      return s;
    }

    DisplaySurface display_surface_from(const PlainMesh &mesh)
    {
      DisplaySurface surface;
      surface.vertices  = mesh.nodes;
      surface.triangles = mesh.triangles;
      merge_duplicate_vertices(surface);
      orient_outward(surface);
      return surface;
    }

    // The faces of the tets that belong to one tet only, oriented outward (for a .msh input,
    // which may not hold boundary triangles at all).
    PlainMesh boundary_of_tets(const PlainMesh &mesh)
    {
      std::map<std::array<unsigned int, 3>, std::pair<int, std::array<unsigned int, 3>>> faces;
      static constexpr int local_faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
      for (const auto &tet : mesh.tets)
        for (const auto &f : local_faces)
          {
            const std::array<unsigned int, 3> face{tet[f[0]], tet[f[1]], tet[f[2]]};
            auto                              sorted = face;
            std::sort(sorted.begin(), sorted.end());
            auto &entry = faces[sorted];
            entry.first += 1;
            entry.second = face;
          }
      PlainMesh boundary;
      boundary.nodes = mesh.nodes;
      for (const auto &entry : faces)
        if (entry.second.first == 1)
          boundary.triangles.push_back(entry.second.second);
      return boundary;
    }

    // Writes the display surface exactly as returned (same vertex order, same orientation), so
    // reading the file back gives the same arrays.
    void write_display_surface(const DisplaySurface &surface, const std::string &path)
    {
      gmsh::clear();
      gmsh::model::add("display_surface");
      const int                entity = gmsh::model::addDiscreteEntity(2);
      std::vector<std::size_t> node_tags(surface.vertices.size()), element_tags(surface.triangles.size()),
        element_nodes;
      std::vector<double> coordinates;
      for (std::size_t v = 0; v < surface.vertices.size(); ++v)
        {
          node_tags[v] = v + 1;
          coordinates.insert(coordinates.end(), surface.vertices[v].begin(), surface.vertices[v].end());
        }
      for (std::size_t t = 0; t < surface.triangles.size(); ++t)
        {
          element_tags[t] = t + 1;
          for (const unsigned int v : surface.triangles[t])
            element_nodes.push_back(v + 1);
        }
      gmsh::model::mesh::addNodes(2, entity, node_tags, coordinates);
      gmsh::model::mesh::addElementsByType(entity, 2, element_tags, element_nodes);
      add_named_group(2, {entity}, "display_surface", 1);
      write_mesh_atomically(path);
    }

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

      SceneMeshes run()
      {
        check_settings(settings);
        if (kind != InputKind::builtin_panel)
          require_readable(settings.geometry, "geometry file");
        else
          check_ribbed_panel(settings.ribbed_panel);
        check_volumes_of_interest(vois, settings, kind);
        create_output_directory();
        inputs = common_inputs();

        SceneMeshes meshes;
        meshes.scenarios.push_back(kind == InputKind::msh ? copy_global_mesh() : mesh_scenario(nullptr));
        for (const auto &voi : vois)
          meshes.scenarios.push_back(mesh_scenario(&voi));
        meshes.display_surface = display_surface();
        return meshes;
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
      std::vector<int>                      field_tags;     // the size fields currently defined

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

      // With reuse_only, a mesh that would have to be made is an error naming it.
      void require_meshing_allowed(const std::string &msh) const
      {
        if (reuse_only)
          throw MeshingError("'" + msh + "' is missing or was made from other inputs, and this run only reuses "
                             "meshes");
      }

      static ScenarioMesh scenario_result(const std::string &name, const std::string &msh, const MeshStatistics &s)
      {
        ScenarioMesh mesh;
        mesh.name       = name;
        mesh.msh_file   = msh;
        mesh.statistics = s;
        auto names      = read_physical_names(msh);
        mesh.physical_surfaces = names[2];
        mesh.physical_volumes  = names[3];
        return mesh;
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

      void add_clamp_from_boxes()
      {
        const std::vector<int> boundary = boundary_faces();
        std::set<int>          clamp;
        for (const auto &box : settings.clamp_boxes)
          {
            Point3 lower, upper;
            for (int i = 0; i < 3; ++i)
              {
                lower[i] = std::min(box[0][i], box[1][i]);
                upper[i] = std::max(box[0][i], box[1][i]);
              }
            for (const int face : entities_inside_box(2, lower, upper, 0.))
              if (std::binary_search(boundary.begin(), boundary.end(), face))
                clamp.insert(face);
          }
        // No face selected: no group. The precompute then says that "clamp" is missing.
        add_named_group(2, {clamp.begin(), clamp.end()}, "clamp", 1);
      }

      void load_geo()
      {
        gmsh::open(settings.geometry);
        DimTags volumes;
        gmsh::model::getEntities(volumes, 3);
        if (volumes.empty())
          throw MeshingError("geometry file '" + settings.geometry + "' defines no volume");
        require_named_groups("geometry file '" + settings.geometry + "'");
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
        option::setNumber("General.NumThreads", settings.mesh_threads);
        if (const char *e = std::getenv("EXP_OPTS")) { std::istringstream in(e); std::string n; double v; while (in >> n >> v) option::setNumber(n, v); }
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

      ScenarioMesh mesh_scenario(const VolumeOfInterest *voi)
      {
        const std::string name = voi ? voi->name : "global";
        const std::string msh = path("mesh_" + name + ".msh"), key_file = path("mesh_" + name + ".key");
        const std::string scenario_inputs = inputs + "; " + (voi ? describe_voi(*voi) : "global");
        const std::string key             = hex(fnv1a(scenario_inputs.data(), scenario_inputs.size()));

        MeshStatistics statistics;
        if (cached(msh, key_file, key, statistics) && statistics.min_quality > settings.min_quality)
          {
            report(name, statistics);
            return scenario_result(name, msh, statistics);
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
        write_key_file(key_file, scenario_inputs, key, statistics);
        report(name, statistics);
        return scenario_result(name, msh, statistics);
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
        const std::string scenario_inputs = inputs + "; global";
        const std::string key             = hex(fnv1a(scenario_inputs.data(), scenario_inputs.size()));
        MeshStatistics    statistics;
        if (cached(msh, key_file, key, statistics) && statistics.min_quality > settings.min_quality)
          {
            report("global", statistics);
            return scenario_result("global", msh, statistics);
          }
        require_meshing_allowed(msh);
        std::error_code ignored;
        fs::remove(key_file, ignored);
        const auto start = std::chrono::steady_clock::now();
        statistics       = check_mesh_quality(settings.geometry, settings.min_quality);
        if (!fs::equivalent(settings.geometry, msh, ignored))
          {
            const std::string temporary = msh + ".tmp";
            std::error_code   error;
            fs::copy_file(settings.geometry, temporary, fs::copy_options::overwrite_existing, error);
            if (error || std::rename(temporary.c_str(), msh.c_str()) != 0)
              throw MeshingError("cannot copy '" + settings.geometry + "' to '" + msh + "'");
          }
        statistics.seconds = seconds_since(start);
        write_key_file(key_file, scenario_inputs, key, statistics);
        report("global", statistics);
        return scenario_result("global", msh, statistics);
      }

      // --- the display surface --------------------------------------------------------------------

      DisplaySurface display_surface()
      {
        const std::string msh = path("display_surface.msh"), key_file = path("display_surface.key");
        std::string       surface_inputs = inputs + "; display surface";
        for (const auto &voi : vois)
          surface_inputs += "; " + describe_voi(voi);
        const std::string key = hex(fnv1a(surface_inputs.data(), surface_inputs.size()));

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
        surface.statistics         = triangle_statistics(surface);
        surface.statistics.reused  = statistics.reused;
        surface.statistics.seconds = statistics.reused ? 0. : seconds_since(start);
        if (!statistics.reused)
          write_key_file(key_file, surface_inputs, key, surface.statistics);
        say("display surface: " + std::to_string(surface.vertices.size()) + " vertices, " +
            std::to_string(surface.triangles.size()) + " triangles" + (statistics.reused ? " (reused)" : ""));
        return surface;
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

  std::map<int, std::map<std::string, int>> read_physical_names(const std::string &msh_file)
  {
    std::ifstream input(msh_file);
    if (!input)
      throw MeshingError("mesh file '" + msh_file + "' does not exist or cannot be read");
    std::map<int, std::map<std::string, int>> names;
    std::string                               line;
    while (std::getline(input, line) && line.rfind("$PhysicalNames", 0) != 0)
      ;
    if (!input)
      return names; // no names in this file
    std::size_t count = 0;
    input >> count;
    std::getline(input, line);
    for (std::size_t i = 0; i < count && std::getline(input, line); ++i)
      {
        std::istringstream entry(line);
        int                dim = -1, tag = 0;
        entry >> dim >> tag;
        const auto first = line.find('"'), last = line.rfind('"');
        if (!entry || first == std::string::npos || last <= first)
          throw MeshingError("mesh file '" + msh_file + "': malformed $PhysicalNames line '" + line + "'");
        names[dim][line.substr(first + 1, last - first - 1)] = tag;
      }
    return names;
  }

  MeshStatistics check_mesh_quality(const std::string &msh_file, const double min_quality)
  {
    require_readable(msh_file, "mesh file");
    GmshSession session(false);
    PlainMesh   mesh;
    call_gmsh("reading mesh file '" + msh_file + "'", [&] {
      gmsh::clear();
      gmsh::open(msh_file);
      mesh = read_current_mesh(true, false);
    });
    return tet_statistics(mesh, min_quality, "mesh file '" + msh_file + "'");
  }
} // namespace modal_haptics::meshing
