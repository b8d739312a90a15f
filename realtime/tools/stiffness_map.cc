#include "stiffness_map.h"

#include <algorithm>
#include <cstdio>
#include <string>
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

  namespace
  {
    // A per-vertex map of space s over its region (the vertices where a contact feels that space):
    // (value, vertex) where value(v) > 0, ascending (ties in vertex order), and the region's size.
    template <typename Value>
    std::vector<std::pair<double, std::uint32_t>> region_values(const modalrt_basis *basis, std::uint32_t s,
                                                               std::uint32_t &region_size, Value value)
    {
      modalrt_basis_info info;
      modalrt_basis_get_info(basis, &info);
      const std::uint32_t                          *regions = modalrt_basis_display_regions(basis);
      std::vector<std::pair<double, std::uint32_t>> values;
      region_size = 0;
      for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
        if (regions[v] == s)
          {
            ++region_size;
            if (value(v) > 0.0)
              values.emplace_back(value(v), v);
          }
      std::sort(values.begin(), values.end());
      return values;
    }

    // "    <label> k: vertex v at (x, y, z) mm: " (the rest position, body frame).
    void print_spot(const modalrt_basis *basis, const char *label, std::size_t k, std::uint32_t vertex)
    {
      const double *x = modalrt_basis_display_vertices(basis) + 3 * std::size_t(vertex);
      std::printf("    %s %zu: vertex %u at (%.3f, %.3f, %.3f) mm: ", label, k + 1, vertex, 1e3 * x[0], 1e3 * x[1],
                  1e3 * x[2]);
    }

    // A validity force as info prints it [N]: "not reached" for the format's 1e30, "-" for no value.
    std::string force_text(double force)
    {
      char text[32];
      if (force >= 1e30)
        return "not reached";
      if (!(force > 0.0))
        return "-";
      std::snprintf(text, sizeof text, "%.4g N", force);
      return text;
    }
  } // namespace

  namespace
  {
    // Per space of the basis: its per-vertex map (`map_of`: the C API's array, NULL without one; then
    // "no map" is printed) and value(map, v) > 0 over its region, ascending (region_values), handed to
    // print(s, space, map, values, region_size).
    template <typename Value, typename Print>
    void print_per_space(const modalrt_basis *basis, const double *(*map_of)(const modalrt_basis *, std::uint32_t),
                         Value value, Print print)
    {
      modalrt_basis_info info;
      modalrt_basis_get_info(basis, &info);
      for (std::uint32_t s = 0; s < info.space_count; ++s)
        {
          modalrt_space_info space;
          modalrt_basis_get_space_info(basis, s, &space);
          const double *map         = map_of(basis, s);
          std::uint32_t region_size = 0;
          const auto    values =
            region_values(basis, s, region_size, [map, &value](std::uint32_t v) { return map ? value(map, v) : 0.0; });
          if (map == nullptr)
            std::printf("  space %u '%s': no map (its region has %u vertices)\n", s, space.name, region_size);
          else
            print(s, space, map, values, region_size);
        }
    }
  } // namespace

  void print_felt_stiffness_map(const modalrt_basis *basis, std::uint32_t softest)
  {
    if (!has_felt_stiffness_map(basis))
      {
        std::printf("\nfelt-stiffness map: none in this file (FELT_STIFFNESS: .mrt 1.1 from a precompute that "
                    "computed it)\n");
        return;
      }
    std::printf("\nfelt-stiffness map (FELT_STIFFNESS: the stiffness pressing straight in along -n, full FE), "
                "each space over its region [N/mm]:\n");
    print_per_space(
      basis, modalrt_basis_felt_stiffness, [](const double *map, std::uint32_t v) { return 1e-3 * map[v]; },
      [&](std::uint32_t s, const modalrt_space_info &space, const double *, const auto &values, std::uint32_t region_size) {
        std::printf("  space %u '%s': %zu of its region's %u vertices", s, space.name, values.size(), region_size);
        if (values.empty())
          {
            std::printf(", none computed\n");
            return;
          }
        const std::size_t n      = values.size();
        const double      median = 0.5 * (values[(n - 1) / 2].first + values[n / 2].first);
        std::printf(": min %.6g / median %.6g / max %.6g N/mm\n", values.front().first, median, values.back().first);
        for (std::size_t k = 0; k < std::min<std::size_t>(softest, n); ++k)
          {
            print_spot(basis, "softest", k, values[k].second);
            std::printf("%.6g N/mm\n", values[k].first);
          }
      });
  }

  bool has_validity_map(const modalrt_basis *basis)
  {
    modalrt_basis_info info{};
    modalrt_basis_get_info(basis, &info);
    for (std::uint32_t s = 0; s < info.space_count; ++s)
      if (modalrt_basis_validity_forces(basis, s))
        return true;
    return false;
  }

  double contact_validity_force(const modalrt_basis *basis, std::uint32_t space, std::uint32_t vertex,
                                std::uint32_t triangle, const double weights[3], std::uint32_t level)
  {
    double force = 0.0;
    if (triangle != MODALRT_NONE)
      modalrt_basis_point_validity_force(basis, space, triangle, weights, level, &force);
    else if (const double *map = modalrt_basis_validity_forces(basis, space))
      force = map[3 * std::size_t(vertex) + (level == 1 ? 0 : level == 10 ? 2 : 1)];
    return force;
  }

  void print_validity_map(const modalrt_basis *basis, std::uint32_t lowest)
  {
    if (!has_validity_map(basis))
      {
        std::printf("\nvalidity map: none in this file (VALIDITY_FORCE: .mrt 1.2 from a precompute with "
                    "'Contact/Validity estimate' or 'Validity analysis')\n");
        return;
      }
    std::printf("\nvalidity map (VALIDITY_FORCE: the contact force up to which the linear felt stiffness holds to "
                "1 / 5 / 10 %%), each space over its region, the lowest F5 first [N]:\n");
    print_per_space(
      basis, modalrt_basis_validity_forces, [](const double *map, std::uint32_t v) { return map[3 * std::size_t(v) + 1]; },
      [&](std::uint32_t s, const modalrt_space_info &space, const double *map, const auto &values, std::uint32_t region_size) {
        std::printf("  space %u '%s': F5 at %zu of its region's %u vertices%s\n", s, space.name, values.size(),
                    region_size, values.empty() ? ", none" : "");
        for (std::size_t k = 0; k < std::min<std::size_t>(lowest, values.size()); ++k)
          {
            const double *F = map + 3 * std::size_t(values[k].second);
            print_spot(basis, "lowest", k, values[k].second);
            std::printf("F1 %s, F5 %s, F10 %s\n", force_text(F[0]).c_str(), force_text(F[1]).c_str(),
                        force_text(F[2]).c_str());
          }
      });
  }

  void print_vertex_validity(const modalrt_basis *basis, std::uint32_t vertex)
  {
    const std::uint32_t region = modalrt_basis_display_regions(basis)[vertex];
    const double       *map    = modalrt_basis_validity_forces(basis, region);
    if (!map)
      {
        std::printf("  validity map: none in its region's space %u\n", region);
        return;
      }
    const double *F = map + 3 * std::size_t(vertex);
    std::printf("  validity map: F1 %s, F5 %s, F10 %s (its region's space %u: the force up to which the felt "
                "stiffness holds to 1 / 5 / 10 %%)\n",
                force_text(F[0]).c_str(), force_text(F[1]).c_str(), force_text(F[2]).c_str(), region);
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
