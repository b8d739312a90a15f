// The display surface's adjacency, built once at load: what a sliding proxy walks over (a triangle's
// neighbour across each edge) and where a contact at a vertex may start (the triangles around it).
#pragma once

#include "allocator.h"

#include <cstdint>

namespace modalrt
{
  struct SurfaceAdjacency
  {
    // 3 per triangle: the triangle across the edge opposite vertex k (the edge from corner k + 1 to
    // corner k + 2), MODALRT_NONE at a boundary or a non-manifold edge (shared by three or more).
    Vector<std::uint32_t> neighbours;
    // The triangles around each vertex: vertex_triangles[vertex_offsets[v] .. vertex_offsets[v + 1]).
    Vector<std::uint32_t> vertex_offsets, vertex_triangles;

    std::uint32_t neighbour(std::uint32_t triangle, int corner) const { return neighbours[3 * std::size_t(triangle) + corner]; }
  };

  // `triangles` (3 nt vertex indices, each < nv, checked by the loader).
  void build_surface_adjacency(const std::uint32_t *triangles, std::uint32_t nt, std::uint32_t nv,
                               SurfaceAdjacency &adjacency);
} // namespace modalrt
