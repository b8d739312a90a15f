// The cross compliance's compressed rows (docs/basis-format.md, sections 28-30): where the block of
// candidates a and b sits. One lookup for the precompute (its validation of pairs) and the kernel.
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
} // namespace mrt
