// The meshing stage's checks: the kind of geometry input, the settings and VOIs before any meshing,
// the quality of a mesh after it.
#include "mesher_parts.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>

namespace modal_haptics::meshing::detail
{
  namespace fs = std::filesystem;

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
    if (extension == ".step" || extension == ".stp" || extension == ".iges" || extension == ".igs" ||
        extension == ".brep")
      return InputKind::cad;
    if (extension == ".geo")
      return InputKind::geo;
    if (extension == ".msh")
      return InputKind::msh;
    throw MeshingError("geometry '" + geometry + "': unknown kind (expected " + builtin_panel +
                       ", .step, .stp, .iges, .igs, .brep, .geo or .msh)");
  }

  // ---------------------------------------------------------------------------------------------
  // Validation of the inputs
  // ---------------------------------------------------------------------------------------------

  void check_settings(const MeshingSettings &settings)
  {
    if (!(settings.coarse_size > 0.))
      throw MeshingError("coarse size must be > 0 (is " + std::to_string(settings.coarse_size) + ")");
    if (settings.mesh_threads < 0)
      throw MeshingError("mesh threads must be >= 0 (0: one per core)");
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
} // namespace modal_haptics::meshing::detail
