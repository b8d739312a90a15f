// The display surface's vertex normals as the contract defines them (docs/basis-format.md): the
// sum of the (doubled-area) normals of the triangles around a vertex, normalized, which follows the
// triangles' outward orientation. The kernel presses along them; the precompute's felt-stiffness
// map is the stiffness along them, so both stages take them from here.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mrt
{
  // vertices: 3 nv [any unit]; triangles: 3 nt; normals: 3 nv, written (0 at a vertex without a triangle).
  void area_weighted_normals(const double *vertices, std::size_t n_vertices, const std::uint32_t *triangles,
                             std::size_t n_triangles, double *normals);
} // namespace mrt
