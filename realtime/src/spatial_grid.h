// A uniform grid over the display vertices at rest: the spatial index that finds the vertices a
// HIP may snap to. Built once at load (CSR of vertex indices per cell), queried without allocation.
#pragma once

#include "allocator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace modalrt
{
  class SpatialGrid
  {
  public:
    // `points`: 3 n coordinates [m]. The cell size is enlarged if needed so that the grid has at
    // most about 2 n + 64 cells (memory stays proportional to the surface).
    void build(const double *points, std::uint32_t n, double cell_size);

    double cell_size() const { return cell_size_; }

    // Calls visit(i) for every point i in the cells that overlap the cube of half-width `radius`
    // around p (a superset of the points within `radius`; the caller measures distances).
    template <typename Visit>
    void for_each_near(const double p[3], double radius, Visit &&visit) const
    {
      if (items_.empty() || !(radius >= 0.0))
        return;
      std::uint32_t lo[3], hi[3];
      for (int d = 0; d < 3; ++d)
        {
          const double a = (p[d] - radius - origin_[d]) * inverse_cell_size_;
          const double b = (p[d] + radius - origin_[d]) * inverse_cell_size_;
          if (b < 0.0 || a >= double(dims_[d]))
            return; // the cube misses the grid
          lo[d] = a <= 0.0 ? 0u : std::uint32_t(a);
          hi[d] = std::uint32_t(std::min(b, double(dims_[d] - 1))); // b >= 0 here
        }
      for (std::uint32_t z = lo[2]; z <= hi[2]; ++z)
        for (std::uint32_t y = lo[1]; y <= hi[1]; ++y)
          for (std::uint32_t x = lo[0]; x <= hi[0]; ++x)
            {
              const std::size_t cell = (std::size_t(z) * dims_[1] + y) * dims_[0] + x;
              for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k)
                visit(items_[k]);
            }
    }

  private:
    double                     origin_[3]        = {0.0, 0.0, 0.0};
    double                     cell_size_        = 1.0;
    double                     inverse_cell_size_ = 1.0;
    std::uint32_t              dims_[3]          = {1, 1, 1};
    modalrt::Vector<std::uint32_t> cell_start_; // CSR: items of cell c are [cell_start_[c], cell_start_[c + 1])
    modalrt::Vector<std::uint32_t> items_;
  };
} // namespace modalrt
