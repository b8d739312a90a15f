#include "design_comparison.h"

#include "stiffness_map.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace modalrt_tool
{
  namespace
  {
    // A scene's felt-stiffness map on its display surface, as mrt::compare_maps reads it.
    struct SceneMap
    {
      const modalrt_basis *basis = nullptr;
      modalrt_basis_info   info{};
      std::vector<double>  stiffness; // [N/m] per display vertex, its region's space's value

      explicit SceneMap(const modalrt_basis *b) : basis(b)
      {
        modalrt_basis_get_info(basis, &info);
        stiffness.resize(info.display_vertex_count);
        for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
          stiffness[v] = scene_felt_stiffness(basis, v);
      }

      mrt::SurfaceMap surface() const
      {
        return {modalrt_basis_display_vertices(basis), info.display_vertex_count,
                modalrt_basis_display_triangles(basis), info.display_triangle_count, stiffness.data()};
      }
    };

    struct BasisDeleter
    {
      void operator()(modalrt_basis *basis) const { modalrt_basis_destroy(basis); }
    };

    bool has_map(const modalrt_basis *basis, const char *path, std::string &error)
    {
      if (has_felt_stiffness_map(basis))
        return true;
      error = std::string("'") + path +
              "' has no felt-stiffness map (FELT_STIFFNESS: .mrt 1.1 from a precompute that computed it): nothing to "
              "compare";
      return false;
    }

    std::string region_name(const modalrt_basis *basis, std::uint32_t vertex)
    {
      modalrt_space_info space;
      modalrt_basis_get_space_info(basis, modalrt_basis_display_regions(basis)[vertex], &space);
      return std::string("'") + space.name + "'";
    }

    void print_rule(const mrt::MapComparison &c, double tolerance)
    {
      if (c.rule == mrt::MatchRule::identity)
        std::printf("  rule            identity: the same display surface (every vertex within %g m of A's), "
                    "vertex i of A is vertex i of B\n",
                    tolerance);
      else
        std::printf("  rule            closest point: the surfaces differ (%zu and %zu vertices), each vertex of A "
                    "is read at the closest point of B's triangles, B's values blended there\n",
                    c.a_vertex_count, c.b_vertex_count);
      std::printf("  match distance  max %.6g mm, 95th percentile %.6g mm\n", 1e3 * c.max_match_distance,
                  1e3 * c.p95_match_distance);
    }

    void print_summary(const mrt::MapComparison &c)
    {
      std::printf("  compared        %zu of A's %zu vertices (%zu without a value in A, %zu without one in B at "
                  "the match)\n",
                  c.compared_count, c.a_vertex_count, c.a_without_value, c.b_without_value);
      if (c.compared_count == 0)
        return;
      std::printf("  ratio B/A       min %.6f / median %.6f / max %.6f\n", c.ratio_min, c.ratio_median, c.ratio_max);
      std::printf("  beyond noise    %zu of %zu vertices differ by more than %g %% (the noise floor: at or below "
                  "it, no difference)\n",
                  c.beyond_noise_count, c.compared_count, c.noise_floor_percent);
    }

    void print_largest(const mrt::MapComparison &c, const modalrt_basis *a)
    {
      if (c.largest.empty())
        return;
      std::printf("  largest differences (by |B - A| / A):\n");
      std::printf("    %3s %8s  %-28s %-12s %12s %12s %13s %9s %11s\n", "#", "vertex", "position [mm]", "region",
                  "A [N/mm]", "B [N/mm]", "B - A [N/mm]", "%", "match [mm]");
      for (std::size_t k = 0; k < c.largest.size(); ++k)
        {
          const mrt::VertexDifference &d = c.largest[k];
          char                         position[64];
          std::snprintf(position, sizeof position, "(%.3f, %.3f, %.3f)", 1e3 * d.position[0], 1e3 * d.position[1],
                        1e3 * d.position[2]);
          std::printf("    %3zu %8u  %-28s %-12s %12.6g %12.6g %+13.6g %+9.3f %11.4g\n", k + 1, d.vertex, position,
                      region_name(a, d.vertex).c_str(), 1e-3 * d.a, 1e-3 * d.b, 1e-3 * (d.b - d.a), d.percent,
                      1e3 * d.match_distance);
        }
    }
  } // namespace

  bool compare_scene_maps(const modalrt_basis *a, const char *path_a, const char *path_b,
                          const DesignComparisonOptions &options, mrt::MapComparison &comparison, std::string &error)
  {
    modalrt_basis *loaded = nullptr;
    if (modalrt_basis_load(path_b, &loaded) != MODALRT_OK)
      {
        error = std::string("bad basis file '") + path_b + "': " + modalrt_last_error_message();
        return false;
      }
    const std::unique_ptr<modalrt_basis, BasisDeleter> b(loaded);
    if (!has_map(a, path_a, error) || !has_map(b.get(), path_b, error))
      return false;
    const SceneMap         map_a(a), map_b(b.get());
    mrt::ComparisonOptions settings;
    settings.noise_floor_percent = options.noise_percent;
    settings.largest_count       = options.largest;
    comparison                   = mrt::compare_maps(map_a.surface(), map_b.surface(), settings);
    return true;
  }

  int compare_designs(const modalrt_basis *a, const char *path_a, const char *path_b,
                      const DesignComparisonOptions &options)
  {
    mrt::MapComparison c;
    std::string        error;
    if (!compare_scene_maps(a, path_a, path_b, options, c, error))
      {
        std::fprintf(stderr, "modal-rt info --compare: %s\n", error.c_str());
        return 1;
      }
    std::printf("felt-stiffness maps compared (each display vertex from its region's space), B read at A's "
                "display vertices:\n");
    std::printf("  A               %s: %zu display vertices\n", path_a, c.a_vertex_count);
    std::printf("  B               %s: %zu display vertices\n", path_b, c.b_vertex_count);
    print_rule(c, mrt::ComparisonOptions().same_position_tolerance);
    print_summary(c);
    print_largest(c, a);
    return 0;
  }
} // namespace modalrt_tool
