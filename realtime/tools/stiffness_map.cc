#include "stiffness_map.h"

#include <algorithm>
#include <cstdio>
#include <utility>
#include <vector>

namespace modalrt_tool
{
  bool has_felt_stiffness_map(const modalrt_basis *basis)
  {
    return modalrt_basis_felt_stiffness(basis, 0) != nullptr;
  }

  double scene_felt_stiffness(const modalrt_basis *basis, std::uint32_t vertex)
  {
    const double *map = modalrt_basis_felt_stiffness(basis, modalrt_basis_display_regions(basis)[vertex]);
    return map ? map[vertex] : 0.0;
  }

  void print_felt_stiffness_map(const modalrt_basis *basis, std::uint32_t softest)
  {
    if (!has_felt_stiffness_map(basis))
      {
        std::printf("\nfelt-stiffness map: none in this file (FELT_STIFFNESS: .mrt 1.1 from a precompute that "
                    "computed it)\n");
        return;
      }
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    const std::uint32_t *regions  = modalrt_basis_display_regions(basis);
    const double        *vertices = modalrt_basis_display_vertices(basis);
    std::printf("\nfelt-stiffness map (FELT_STIFFNESS: the stiffness pressing straight in along -n, full FE), "
                "each space over its region [N/mm]:\n");
    for (std::uint32_t s = 0; s < info.space_count; ++s)
      {
        modalrt_space_info space;
        modalrt_basis_get_space_info(basis, s, &space);
        const double                                *map = modalrt_basis_felt_stiffness(basis, s);
        std::vector<std::pair<double, std::uint32_t>> values; // (N/mm, vertex), computed vertices of the region
        std::uint32_t                                 region_size = 0;
        for (std::uint32_t v = 0; v < info.display_vertex_count && map == nullptr; ++v)
          region_size += regions[v] == s;
        if (map == nullptr)
          {
            std::printf("  space %u '%s': no map (its region has %u vertices)\n", s, space.name, region_size);
            continue;
          }
        for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
          if (regions[v] == s)
            {
              ++region_size;
              if (map[v] > 0.0)
                values.emplace_back(1e-3 * map[v], v);
            }
        std::printf("  space %u '%s': %zu of its region's %u vertices", s, space.name, values.size(), region_size);
        if (values.empty())
          {
            std::printf(", none computed\n");
            continue;
          }
        std::sort(values.begin(), values.end());
        const std::size_t n      = values.size();
        const double      median = 0.5 * (values[(n - 1) / 2].first + values[n / 2].first);
        std::printf(": min %.6g / median %.6g / max %.6g N/mm\n", values.front().first, median, values.back().first);
        for (std::size_t k = 0; k < std::min<std::size_t>(softest, n); ++k)
          {
            const double *x = vertices + 3 * std::size_t(values[k].second);
            std::printf("    softest %zu: vertex %u at (%.3f, %.3f, %.3f) mm: %.6g N/mm\n", k + 1, values[k].second,
                        1e3 * x[0], 1e3 * x[1], 1e3 * x[2], values[k].first);
          }
      }
  }

  void print_vertex_felt_stiffness(const modalrt_basis *basis, std::uint32_t vertex)
  {
    if (!has_felt_stiffness_map(basis))
      {
        std::printf("  felt-stiffness map: none in this file\n");
        return;
      }
    const std::uint32_t region = modalrt_basis_display_regions(basis)[vertex];
    const double        k      = scene_felt_stiffness(basis, vertex);
    if (k > 0.0)
      std::printf("  felt-stiffness map: %.12g N/mm (its region's space %u, full FE)\n", 1e-3 * k, region);
    else
      std::printf("  felt-stiffness map: not computed here (0 in its region's space %u)\n", region);
  }
} // namespace modalrt_tool
