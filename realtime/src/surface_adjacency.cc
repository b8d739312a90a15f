#include "surface_adjacency.h"

#include <algorithm>
#include <vector>

namespace modalrt
{
  namespace
  {
    struct Edge
    {
      std::uint32_t low, high, triangle;
      int           corner; // the corner opposite the edge
      bool operator<(const Edge &o) const { return low != o.low ? low < o.low : high != o.high ? high < o.high : triangle < o.triangle; }
    };
  } // namespace

  // Edges sorted by their two vertices: an edge met exactly twice joins two neighbours.
  void build_surface_adjacency(const std::uint32_t *triangles, std::uint32_t nt, std::uint32_t nv,
                               SurfaceAdjacency &adjacency)
  {
    std::vector<Edge> edges;
    edges.reserve(3 * std::size_t(nt));
    for (std::uint32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k)
        {
          const std::uint32_t a = triangles[3 * std::size_t(t) + (k + 1) % 3], b = triangles[3 * std::size_t(t) + (k + 2) % 3];
          edges.push_back({std::min(a, b), std::max(a, b), t, k});
        }
    std::sort(edges.begin(), edges.end());
    adjacency.neighbours.assign(3 * std::size_t(nt), MODALRT_NONE);
    for (std::size_t first = 0, last; first < edges.size(); first = last)
      {
        last = first + 1;
        while (last < edges.size() && edges[last].low == edges[first].low && edges[last].high == edges[first].high)
          ++last;
        if (last - first != 2)
          continue;
        const Edge &e = edges[first], &f = edges[first + 1];
        adjacency.neighbours[3 * std::size_t(e.triangle) + e.corner] = f.triangle;
        adjacency.neighbours[3 * std::size_t(f.triangle) + f.corner] = e.triangle;
      }

    adjacency.vertex_offsets.assign(std::size_t(nv) + 1, 0);
    for (std::size_t k = 0; k < 3 * std::size_t(nt); ++k)
      ++adjacency.vertex_offsets[triangles[k] + 1];
    for (std::uint32_t v = 0; v < nv; ++v)
      adjacency.vertex_offsets[v + 1] += adjacency.vertex_offsets[v];
    adjacency.vertex_triangles.assign(3 * std::size_t(nt), 0);
    std::vector<std::uint32_t> fill(adjacency.vertex_offsets.begin(), adjacency.vertex_offsets.end() - 1);
    for (std::uint32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k)
        adjacency.vertex_triangles[fill[triangles[3 * std::size_t(t) + k]]++] = t;
  }
} // namespace modalrt
