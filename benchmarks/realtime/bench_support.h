// Helpers shared by the kernel benchmarks (bench-kernel-tick, bench-display).
#pragma once

#include "synthetic_scene.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace modalrt_bench
{
  // Loads the analytic plate through the kernel's own loader, as a .mrt file would be.
  inline modalrt_basis *load_plate(const modalrt::PlateOptions &plate, const char *program)
  {
    std::vector<unsigned char> bytes = modalrt::write_basis(modalrt::make_analytic_plate(plate));
    modalrt_basis             *basis = nullptr;
    if (modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis) != MODALRT_OK)
      {
        std::fprintf(stderr, "%s: %s\n", program, modalrt_last_error_message());
        std::exit(1);
      }
    return basis;
  }

  struct Spread
  {
    double median, min, max;
  };

  inline Spread spread(std::vector<double> values)
  {
    std::sort(values.begin(), values.end());
    return {values[values.size() / 2], values.front(), values.back()};
  }
} // namespace modalrt_bench
