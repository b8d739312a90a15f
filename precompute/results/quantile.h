#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace modal_haptics
{
  // The one rule for the quantiles the precompute reports (report.json, the log): the value of rank
  // round(q (n - 1)) among n values in ascending order (q = 0.5 of an even count: the upper middle).
  inline std::size_t quantile_rank(const std::size_t n, const double q)
  {
    return n == 0 ? 0 : std::min(n - 1, std::size_t(q * double(n - 1) + 0.5));
  }

  // The q-quantile of unsorted values (0 when there are none).
  inline double quantile(std::vector<double> values, const double q)
  {
    if (values.empty())
      return 0.;
    const auto at = values.begin() + std::ptrdiff_t(quantile_rank(values.size(), q));
    std::nth_element(values.begin(), at, values.end());
    return *at;
  }
} // namespace modal_haptics
