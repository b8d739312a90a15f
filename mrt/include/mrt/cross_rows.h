// The cross compliance's compressed rows (docs/basis-format.md, sections 28-30): where the block of
// candidates a and b sits; and the far field's coupling of a pair without a block (section 34). One
// rule for the precompute (its validation of pairs) and the kernel.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

namespace mrt
{
  // The position of neighbour b in candidate a's row (its block is at 9 times that in the blocks),
  // or -1 when the pair is not stored.
  inline std::ptrdiff_t cross_position(const std::uint32_t *offsets, const std::uint32_t *neighbours, std::uint32_t a,
                                       std::uint32_t b)
  {
    const std::uint32_t *first = neighbours + offsets[a], *last = neighbours + offsets[a + 1];
    const std::uint32_t *found = std::lower_bound(first, last, b);
    return found != last && *found == b ? found - neighbours : -1;
  }

  // C = Z_a Z_b^T (3 x 3 row-major) from the far field's rank-k rows (3 per candidate, k each:
  // FAR_COMPLIANCE); zero when k = 0. No allocation.
  inline void far_coupling(const double *Z, std::uint32_t k, std::uint32_t a, std::uint32_t b, double C[9])
  {
    for (std::uint32_t i = 0; i < 3; ++i)
      for (std::uint32_t d = 0; d < 3; ++d)
        {
          const double *za = Z + (3 * std::size_t(a) + i) * k, *zb = Z + (3 * std::size_t(b) + d) * k;
          double        sum = 0.0;
          for (std::uint32_t j = 0; j < k; ++j)
            sum += za[j] * zb[j];
          C[3 * i + d] = sum;
        }
  }
} // namespace mrt
