// A variant's felt-stiffness map against the base's: mrt's compare_maps (the one matching rule of both
// stages) turned into report.json's record, its differences judged region by region. No deal.II.
#include "pipeline/design_comparison.h"

#include "results/quantile.h"

#include <mrt/map_comparison.h>

#include <cmath>

namespace modal_haptics
{
  namespace
  {
    mrt::SurfaceMap surface_map(const FeltStiffnessMap &map)
    {
      mrt::SurfaceMap surface;
      surface.vertices       = map.vertices.data();
      surface.vertex_count   = map.stiffness.size();
      surface.triangles      = map.triangles.data();
      surface.triangle_count = map.triangles.size() / 3;
      surface.stiffness      = map.stiffness.data();
      return surface;
    }

    // The figures of the compared vertices for which 'selected' holds, each judged by floor(v).
    template <typename Selected, typename Floor>
    DifferenceFigures figures(const mrt::MapComparison &comparison, const std::string &name, const Selected &selected,
                              const Floor &floor)
    {
      DifferenceFigures   f;
      std::vector<double> signed_percent, absolute_percent;
      bool                stiffer = false, softer = false;
      f.name = name;
      for (std::size_t v = 0; v < comparison.compared.size(); ++v)
        if (comparison.compared[v] && selected(v))
          {
            const double percent = comparison.percent[v];
            signed_percent.push_back(percent);
            absolute_percent.push_back(std::abs(percent));
            f.noise_floor_percent = std::max(f.noise_floor_percent, floor(v));
            if (std::abs(percent) > floor(v))
              {
                ++f.beyond_noise_vertices;
                (percent > 0. ? stiffer : softer) = true;
              }
          }
      f.compared_vertices = signed_percent.size();
      f.median_percent    = quantile(signed_percent, 0.5);
      f.p95_abs_percent   = quantile(absolute_percent, 0.95);
      f.max_abs_percent   = quantile(absolute_percent, 1.);
      f.verdict           = stiffer && softer ? "mixed" : stiffer ? "stiffer" : softer ? "softer" : "none";
      return f;
    }
  } // namespace

  MapComparisonRecord compare_felt_stiffness(const FeltStiffnessMap &base, const FeltStiffnessMap &variant,
                                             const std::vector<double> &floors_percent, const std::size_t largest_count)
  {
    mrt::ComparisonOptions options;
    options.largest_count       = largest_count;
    options.noise_floor_percent = 0.; // each vertex is judged by its region's floor below
    const mrt::MapComparison comparison = mrt::compare_maps(surface_map(base), surface_map(variant), options);
    // The identity rule compares maps on the same meshes: no re-meshing noise, only the solves' precision.
    const bool identity = comparison.rule == mrt::MatchRule::identity;
    const auto floor    = [&](const std::size_t v) {
      return identity ? identity_noise_floor_percent :
                        base.region[v] < floors_percent.size() ? floors_percent[base.region[v]] : 0.;
    };

    MapComparisonRecord record;
    record.rule                 = mrt::match_rule_name(comparison.rule);
    record.base_vertices        = comparison.a_vertex_count;
    record.max_match_distance_m = comparison.max_match_distance;
    record.p95_match_distance_m = comparison.p95_match_distance;
    record.ratio_min            = comparison.ratio_min;
    record.ratio_median         = comparison.ratio_median;
    record.ratio_max            = comparison.ratio_max;
    record.all = figures(comparison, "", [](std::size_t) { return true; }, floor);
    for (unsigned int r = 0; r < base.region_names.size(); ++r)
      record.regions.push_back(
        figures(comparison, base.region_names[r], [&](const std::size_t v) { return base.region[v] == r; }, floor));
    for (const auto &d : comparison.largest)
      record.largest.push_back({d.vertex,
                                {{d.position[0], d.position[1], d.position[2]}},
                                d.a,
                                d.b,
                                d.percent,
                                d.match_distance,
                                std::abs(d.percent) > floor(d.vertex)});
    return record;
  }
} // namespace modal_haptics
