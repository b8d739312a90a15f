// A variant's felt-stiffness map against the base's: mrt's compare_maps (the one matching rule of both
// stages) turned into report.json's record. No deal.II.
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

    // The signed and absolute % differences over the compared vertices.
    void add_percent_statistics(const mrt::MapComparison &comparison, MapComparisonRecord &record)
    {
      std::vector<double> signed_percent, absolute_percent;
      for (std::size_t v = 0; v < comparison.compared.size(); ++v)
        if (comparison.compared[v])
          {
            signed_percent.push_back(comparison.percent[v]);
            absolute_percent.push_back(std::abs(comparison.percent[v]));
          }
      record.median_percent  = quantile(signed_percent, 0.5);
      record.p95_abs_percent = quantile(absolute_percent, 0.95);
      record.max_abs_percent = quantile(absolute_percent, 1.);
    }

    // Which way the differences beyond the floor go.
    std::string verdict(const mrt::MapComparison &comparison)
    {
      bool stiffer = false, softer = false;
      for (std::size_t v = 0; v < comparison.compared.size(); ++v)
        if (comparison.compared[v] && std::abs(comparison.percent[v]) > comparison.noise_floor_percent)
          (comparison.percent[v] > 0. ? stiffer : softer) = true;
      return stiffer && softer ? "mixed" : stiffer ? "stiffer" : softer ? "softer" : "none";
    }
  } // namespace

  MapComparisonRecord compare_felt_stiffness(const FeltStiffnessMap &base, const FeltStiffnessMap &variant,
                                             const double noise_floor_percent, const std::size_t largest_count)
  {
    mrt::ComparisonOptions options;
    options.largest_count       = largest_count;
    options.noise_floor_percent = noise_floor_percent;
    mrt::MapComparison comparison = mrt::compare_maps(surface_map(base), surface_map(variant), options);
    // The identity rule compares maps on the same meshes: no re-meshing noise, only the solves' precision.
    if (comparison.rule == mrt::MatchRule::identity && noise_floor_percent != identity_noise_floor_percent)
      {
        options.noise_floor_percent = identity_noise_floor_percent;
        comparison                  = mrt::compare_maps(surface_map(base), surface_map(variant), options);
      }

    MapComparisonRecord record;
    record.rule                  = mrt::match_rule_name(comparison.rule);
    record.compared_vertices     = comparison.compared_count;
    record.base_vertices         = comparison.a_vertex_count;
    record.max_match_distance_m  = comparison.max_match_distance;
    record.p95_match_distance_m  = comparison.p95_match_distance;
    record.ratio_min             = comparison.ratio_min;
    record.ratio_median          = comparison.ratio_median;
    record.ratio_max             = comparison.ratio_max;
    record.noise_floor_percent   = comparison.noise_floor_percent;
    record.beyond_noise_vertices = comparison.beyond_noise_count;
    record.verdict               = verdict(comparison);
    add_percent_statistics(comparison, record);
    for (const auto &d : comparison.largest)
      record.largest.push_back({d.vertex,
                                {{d.position[0], d.position[1], d.position[2]}},
                                d.a,
                                d.b,
                                d.percent,
                                d.match_distance,
                                std::abs(d.percent) > comparison.noise_floor_percent});
    return record;
  }
} // namespace modal_haptics
