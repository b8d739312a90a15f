#include <mrt/surface_normals.h>

#include <algorithm>
#include <cmath>

namespace mrt
{
  void area_weighted_normals(const double *x, const std::size_t n_vertices, const std::uint32_t *triangles,
                             const std::size_t n_triangles, double *normals)
  {
    std::fill_n(normals, 3 * n_vertices, 0.0);
    for (std::size_t t = 0; t < n_triangles; ++t)
      {
        const std::uint32_t *tri = &triangles[3 * t];
        double               e1[3], e2[3];
        for (int d = 0; d < 3; ++d)
          {
            e1[d] = x[3 * tri[1] + d] - x[3 * tri[0] + d];
            e2[d] = x[3 * tri[2] + d] - x[3 * tri[0] + d];
          }
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; ++k)
          for (int d = 0; d < 3; ++d)
            normals[3 * tri[k] + d] += n[d];
      }
    for (std::size_t v = 0; v < n_vertices; ++v)
      {
        double      *n = &normals[3 * v];
        const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int d = 0; d < 3; ++d)
          n[d] = l > 0.0 ? n[d] / l : 0.0;
      }
  }
} // namespace mrt
