// The scene's display surface (DESIGN.md) as the modal spaces see it, the contact surface: the
// mesher's meshing::DisplaySurface in SI units, with what every modal space shares on it:
// the region tag of each vertex (which VOI holds it), the lumped vertex areas and the contact
// patches (the weights that spread a HIP's force around its active vertex).
#pragma once

#include "scene_mesher.h"

#include <mrt/surface_normals.h>

#include <array>
#include <vector>

namespace modal_haptics
{
  struct ContactSurface
  {
    std::vector<meshing::Point3>             vertices;  // [m]
    std::vector<std::array<unsigned int, 3>> triangles;
    std::vector<double>       vertex_area;   // a third of the adjacent triangles' area [m^2]
    std::vector<unsigned int> region;        // space index whose VOI holds the vertex, 0 = global
    double                    patch_radius = 0.; // rho [m]
    // Contact patches, CSR: the patch of v is entries [patch_offsets[v], patch_offsets[v+1]),
    // its first entry is v itself; weights sum to one.
    std::vector<unsigned int> patch_offsets;
    std::vector<unsigned int> patch_vertices;
    std::vector<double>       patch_weights;
    unsigned int              max_patch_size = 0;
    // A patch over this many display vertices is warned about: the patch radius is large against
    // the display surface's fine size (a radius in the wrong unit, say), the .mrt grows with it and
    // every contact's tick reads that many vertices. The default scene's patches hold up to 12.
    static constexpr unsigned int patch_size_warning = 64;
    // The triangles around each vertex, CSR: entries [vertex_triangle_offsets[v], ...[v+1]).
    std::vector<unsigned int> vertex_triangle_offsets;
    std::vector<unsigned int> vertex_triangles;

    unsigned int n_vertices() const { return vertices.size(); }
  };

  // Rows of 3 (points, triangles) as one flat array, row after row: the layout of the .h5, the
  // .mrt and the geometry helpers that take positions[3 v + c].
  inline std::vector<double> flatten(const std::vector<meshing::Point3> &points)
  {
    std::vector<double> flat;
    for (const auto &p : points)
      flat.insert(flat.end(), p.begin(), p.end());
    return flat;
  }

  template <std::size_t N>
  std::vector<unsigned int> flatten(const std::vector<std::array<unsigned int, N>> &rows)
  {
    std::vector<unsigned int> flat;
    for (const auto &row : rows)
      flat.insert(flat.end(), row.begin(), row.end());
    return flat;
  }

  // The outward normal at every display vertex, 3 per vertex: the one the kernel presses along
  // (mrt::area_weighted_normals, the .mrt contract's), so a report names the direction a spot is felt in.
  inline std::vector<double> vertex_normals(const ContactSurface &surface)
  {
    const std::vector<double>       positions = flatten(surface.vertices);
    const std::vector<unsigned int> triangles = flatten(surface.triangles);
    std::vector<double>             normals(positions.size());
    mrt::area_weighted_normals(positions.data(), surface.n_vertices(), triangles.data(), surface.triangles.size(),
                               normals.data());
    return normals;
  }

  // A point of a quadrature over the display surface [m] and its weight [-].
  struct SurfacePoint
  {
    meshing::Point3 x;
    double          weight;
  };

  // The contact patch of a vertex as a surface traction: the density w(x) ~ (1 - (|x - x_v| / rho)^2)^2
  // integrated over the display triangles that touch the patch, each split into sub-triangles no
  // larger than rho / 2 with a degree-2 rule. Weights sum to one; rho = 0 gives the vertex alone.
  // The static solves load the FE mesh with this quadrature (the consistent load of the traction),
  // not with point forces at the patch vertices: on P2 meshes point forces at vertices are a sum of
  // singular loads whose response converges slowly under refinement.
  std::vector<SurfacePoint> patch_quadrature(const ContactSurface &surface, unsigned int vertex);

  // Scales the mesher's surface to metres, tags each vertex with the first VOI (1-based, in the order
  // given) that contains it, and builds the patches of radius patch_radius [m]:
  // w_j ~ A_j (1 - (d_j / rho)^2)^2 for d_j < rho, normalized (rho = 0: the vertex alone).
  ContactSurface make_display_surface(const meshing::DisplaySurface                &surface,
                                      const std::vector<meshing::VolumeOfInterest> &volumes_of_interest,
                                      double length_unit,
                                      double patch_radius);
} // namespace modal_haptics
