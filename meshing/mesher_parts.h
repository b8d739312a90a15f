// Internal: the parts of the meshing stage that scene_mesher.cc's driver uses, one file per job:
// mesh_checks.cc (inputs before meshing, quality after), mesh_cache.cc (cache keys and key files),
// display_surface_mesh.cc (the display surface). Plain C++17; gmsh stays in the .cc files.
#pragma once

#include "gmsh_tools.h"
#include "scene_mesher.h"

#include <array>
#include <cstddef>
#include <functional>
#include <cstdint>
#include <string>
#include <vector>

namespace modal_haptics::meshing::detail
{
  inline constexpr const char *builtin_panel = "builtin:ribbed_panel";

  // ---- mesh_checks.cc ----------------------------------------------------------------------------
  enum class InputKind { builtin_panel, cad, geo, msh };

  std::string lower_case(std::string text);
  // The kind of a geometry input, from "builtin:..." or the file's extension; throws MeshingError.
  InputKind input_kind(const std::string &geometry);

  // Throw MeshingError naming the setting or the VOI and its value.
  void check_settings(const MeshingSettings &settings);
  void check_volumes_of_interest(const std::vector<VolumeOfInterest> &vois, const MeshingSettings &settings,
                                 InputKind kind);

  // Quality statistics of the tets; throws naming the worst element when it is not acceptable.
  MeshStatistics tet_statistics(const PlainMesh &mesh, double min_quality, const std::string &what);
  bool           any_node_inside(const PlainMesh &mesh, const VolumeOfInterest &voi);
  std::string    not_intersecting_message(const VolumeOfInterest &voi, const std::string &why);

  // ---- geometry_queries.cc (the loaded gmsh model) ------------------------------------------------
  double                part_volume(); // [unit^3] from OpenCASCADE; 0 for gmsh's built-in kernel
  std::array<Point3, 2> bounding_box(int dim = -1, int tag = -1); // the part's, or an entity's [unit]
  double growth_to_catch(const std::array<Point3, 2> &box, const std::array<Point3, 2> &face);
  double face_area(int face);  // from OpenCASCADE
  double mesh_area(int face);  // from a .msh's triangles
  double box_gap(const std::array<Point3, 2> &region, const std::array<Point3, 2> &box); // <= 0: they meet
  // The boundary faces whose bounding box b has gap(b) <= 0; with none, 'why' names the nearest.
  SelectionReport faces_meeting(const std::string &name, const std::function<double(const std::array<Point3, 2> &)> &gap,
                                std::string &why);
  // A named physical group of dimension 'dim' (refused when missing, listing those that exist).
  SelectionReport inspect_group(InputKind kind, const std::string &geometry, int dim, const std::string &name);
  // A support's box or plane: refused when no boundary face's bounding box meets it.
  SelectionReport inspect_region(const RegionSelection &selection, const std::string &geometry);

  // ---- mesh_cache.cc -----------------------------------------------------------------------------
  // FNV-1a, 64 bit: enough to tell whether the inputs of a mesh changed (not a security hash).
  std::uint64_t fnv1a(const char *data, std::size_t size, std::uint64_t hash = 14695981039346656037ull);
  std::string   hex(std::uint64_t value);
  // The cache key of a mesh: the hash of the text that describes every input it depends on.
  std::string key_of(const std::string &inputs);

  void        require_readable(const std::string &file, const std::string &what);
  std::string file_content_hash(const std::string &file);
  std::string describe_point(const Point3 &p);  // exact, for keys
  std::string readable_point(const Point3 &p);  // short, for messages
  std::string describe_voi(const VolumeOfInterest &voi);    // exact, for keys
  std::string describe_region(const VolumeOfInterest &voi); // short, for messages

  // What a cache key file holds: the hash of the inputs and the statistics of the mesh it made.
  struct KeyFile
  {
    std::string    key;
    MeshStatistics statistics;
  };
  bool read_key_file(const std::string &path, KeyFile &content);
  void write_key_file(const std::string &path, const std::string &inputs, const std::string &key,
                      const MeshStatistics &s);

  // ---- display_surface_mesh.cc -------------------------------------------------------------------
  MeshStatistics triangle_statistics(const DisplaySurface &surface);
  // Merged duplicate vertices, consistent outward orientation.
  DisplaySurface display_surface_from(const PlainMesh &mesh);
  // The faces of the tets that belong to one tet only, oriented outward (for a .msh input).
  PlainMesh boundary_of_tets(const PlainMesh &mesh);
  // Writes the surface exactly as returned (same vertex order and orientation), into the current
  // gmsh session (which it clears).
  void write_display_surface(const DisplaySurface &surface, const std::string &path);
} // namespace modal_haptics::meshing::detail
