#include "spatial_grid.h"

namespace modalrt
{
  void SpatialGrid::build(const double *points, std::uint32_t n, double cell_size)
  {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (std::uint32_t i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d)
        {
          lo[d] = std::min(lo[d], points[3 * i + d]);
          hi[d] = std::max(hi[d], points[3 * i + d]);
        }
    if (n == 0)
      for (int d = 0; d < 3; ++d)
        lo[d] = hi[d] = 0.0;

    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-9});
    double       h      = cell_size > 0.0 && std::isfinite(cell_size) ? cell_size : extent;
    const double max_cells = 2.0 * n + 64.0;
    for (;;)
      {
        double cells = 1.0;
        for (int d = 0; d < 3; ++d)
          cells *= std::floor((hi[d] - lo[d]) / h) + 1.0;
        if (cells <= max_cells)
          break;
        h *= 1.25;
      }

    cell_size_         = h;
    inverse_cell_size_ = 1.0 / h;
    for (int d = 0; d < 3; ++d)
      {
        origin_[d] = lo[d];
        dims_[d]   = std::uint32_t(std::floor((hi[d] - lo[d]) / h)) + 1u;
      }

    const std::size_t          n_cells = std::size_t(dims_[0]) * dims_[1] * dims_[2];
    modalrt::Vector<std::uint32_t> cell_of(n);
    cell_start_.assign(n_cells + 1, 0);
    for (std::uint32_t i = 0; i < n; ++i)
      {
        std::uint32_t c[3];
        for (int d = 0; d < 3; ++d)
          c[d] = std::min(dims_[d] - 1, std::uint32_t((points[3 * i + d] - origin_[d]) * inverse_cell_size_));
        cell_of[i] = std::uint32_t((std::size_t(c[2]) * dims_[1] + c[1]) * dims_[0] + c[0]);
        ++cell_start_[cell_of[i] + 1];
      }
    for (std::size_t c = 0; c < n_cells; ++c)
      cell_start_[c + 1] += cell_start_[c];
    items_.resize(n);
    modalrt::Vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::uint32_t i = 0; i < n; ++i)
      items_[fill[cell_of[i]]++] = i;
  }
} // namespace modalrt
