// The snap search (snap_search.h).
#include "snap_search.h"

#include "dense.h"
#include "vector3.h"

#include <cmath>

using namespace modalrt;

void SnapSearch::setup(std::uint32_t budget) { candidates_.resize(budget); }

// The closest vertex of the deformed surface. The grid gives the vertices whose rest position is
// within snap_distance plus a bound on every displacement; the snap_candidate_budget nearest of
// them at rest are evaluated deformed (bounded work per tick).
bool SnapSearch::find(const modalrt_basis &basis, std::uint32_t space_index, const double *q, double snap_distance,
                      const double x[3], std::uint32_t &vertex, double gap[3], double &signed_distance) noexcept
{
  const ModalSpace   &space = basis.spaces[space_index];
  const std::uint32_t r     = space.mode_count;
  double              q_norm = 0.0;
  for (std::uint32_t i = 0; i < r; ++i)
    q_norm += q[i] * q[i];
  q_norm                 = std::sqrt(q_norm);
  const double radius    = snap_distance + space.max_vertex_mode_norm * q_norm;
  const double radius2   = radius * radius;
  const std::uint32_t budget = std::uint32_t(candidates_.size());
  std::uint32_t       found  = 0;
  vertex                     = MODALRT_NONE;

  basis.grid.for_each_near(x, radius, [&](std::uint32_t v) {
    const double *p  = &basis.vertices[3 * std::size_t(v)];
    const double  d2 = (x[0] - p[0]) * (x[0] - p[0]) + (x[1] - p[1]) * (x[1] - p[1]) + (x[2] - p[2]) * (x[2] - p[2]);
    if (d2 > radius2)
      return;
    if (found < budget)
      {
        candidates_[found++] = {v, d2};
        return;
      }
    std::uint32_t farthest = 0;
    for (std::uint32_t k = 1; k < budget; ++k)
      if (candidates_[k].rest_distance_squared > candidates_[farthest].rest_distance_squared)
        farthest = k;
    if (d2 < candidates_[farthest].rest_distance_squared)
      candidates_[farthest] = {v, d2};
  });

  double best = HUGE_VAL, best_position[3] = {0, 0, 0};
  for (std::uint32_t k = 0; k < found; ++k)
    {
      const std::uint32_t v = candidates_[k].vertex;
      double              p[3], u[3] = {0.0, 0.0, 0.0};
      if (q_norm > 0.0)
        vertex_displacement(basis, space, v, q, u);
      for (int d = 0; d < 3; ++d)
        p[d] = basis.vertices[3 * std::size_t(v) + d] + u[d];
      const double d2 = (x[0] - p[0]) * (x[0] - p[0]) + (x[1] - p[1]) * (x[1] - p[1]) + (x[2] - p[2]) * (x[2] - p[2]);
      if (d2 < best || (d2 == best && v < vertex))
        {
          best   = d2;
          vertex = v;
          std::copy_n(p, 3, best_position);
        }
    }
  if (found == 0 || best > snap_distance * snap_distance)
    return false;
  for (int d = 0; d < 3; ++d)
    gap[d] = x[d] - best_position[d];
  signed_distance = dot3(gap, &basis.normals[3 * std::size_t(vertex)]);
  return true;
}

void modalrt::vertex_displacement(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, const double *q,
                                  double u[3]) noexcept
{
  const std::uint32_t r     = space.mode_count;
  const std::size_t   first = std::size_t(v) * 3 * r;
  for (int c = 0; c < 3; ++c)
    u[c] = basis.float64_modes() ? dot(&space.display_modes_f64[first + c * r], q, r)
                                 : dot(&space.display_modes_f32[first + c * r], q, r);
}
