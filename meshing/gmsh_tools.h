// Internal helpers of the meshing stage around gmsh's C++ API (not installed, not seen by the
// precompute): the process-wide gmsh session, error translation, physical groups, and reading the
// current mesh back into plain arrays.
#pragma once

#include "scene_mesher.h"

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace modal_haptics::meshing::detail
{
  // gmsh must be initialized once and finalized at the end. Sessions nest (mesh_scene calls
  // check_mesh_quality, a caller may call mesh_scene several times): the first one initializes,
  // the last one to end finalizes.
  class GmshSession
  {
  public:
    explicit GmshSession(bool verbose);
    ~GmshSession();
    GmshSession(const GmshSession &)            = delete;
    GmshSession &operator=(const GmshSession &) = delete;
  };

  // Runs a block of gmsh calls. gmsh 4.8 reports errors by throwing std::string (or, from some
  // paths, std::exception); both become a MeshingError whose message starts with 'context'.
  void call_gmsh(const std::string &context, const std::function<void()> &block);

  // The gmsh version string of the library actually loaded (part of every cache key).
  std::string gmsh_version();

  using DimTags = std::vector<std::pair<int, int>>;

  // Entities of dimension 'dim' whose bounding box lies inside [lower, upper] (+- tolerance).
  std::vector<int> entities_inside_box(int dim, const Point3 &lower, const Point3 &upper, double tolerance);

  // The faces that bound the model's volumes (faces shared by two volumes are not boundary).
  std::vector<int> boundary_faces();

  // Tag and name of every physical group of dimension 'dim' of the current model.
  std::vector<std::pair<int, std::string>> physical_groups(int dim);

  // Adds a named physical group; does nothing for an empty entity list (an empty group would be
  // written as a group without elements, which readers then silently accept).
  void add_named_group(int dim, const std::vector<int> &entities, const std::string &name, int tag);

  // Every physical group of the model must be named (deal.II reads the names); throws otherwise.
  // Returns (dimension, name) of each name whose group holds no entity (gmsh loads 'Physical
  // Surface("wall") = {};' without a word), removed from the model: the caller warns about them and
  // refuses a selection that names one.
  std::vector<std::pair<int, std::string>> require_named_groups(const std::string &context);

  // "the physical surface 'wall' holds no surface (gmsh loads ... without a word)": for messages.
  std::string empty_group_words(int dim, const std::string &name);

  // Whether complete_physical_groups added this group (not the user's): "free", "part".
  bool added_by_program(int dim, const std::string &name);

  // Makes the model writable for the precompute: a volume group "part" if there is no volume
  // group, and every boundary face not yet in a physical surface goes to the surface group "free".
  void complete_physical_groups();

  // The current model's mesh as plain arrays: node coordinates indexed by compact numbers 0..n-1
  // and linear elements referring to them. Element tags are kept for error messages.
  struct PlainMesh
  {
    std::vector<Point3>                      nodes;
    std::vector<std::array<unsigned int, 4>> tets;
    std::vector<std::size_t>                 tet_tags;
    std::vector<std::array<unsigned int, 3>> triangles;
  };
  // With only_triangle_nodes the nodes are the ones used by triangles only (the display surface).
  PlainMesh read_current_mesh(bool with_tets, bool only_triangle_nodes);

  // Writes the current model's mesh as MSH 4.1 ASCII (elements of physical groups only) to a
  // temporary name beside 'path', then renames it into place, so a reader never sees half a file.
  void write_mesh_atomically(const std::string &path);

  // Signed inverse condition number of a linear tet relative to the regular tet: 1 for the regular
  // tet, -> 0 when degenerate, < 0 when inverted. For straight tets this is gmsh's SICN measure.
  double tet_sicn(const Point3 &a, const Point3 &b, const Point3 &c, const Point3 &d);

  // 4 sqrt(3) area / (sum of squared edges): 1 for the equilateral triangle, 0 when degenerate.
  double triangle_shape_quality(const Point3 &a, const Point3 &b, const Point3 &c);
} // namespace modal_haptics::meshing::detail
