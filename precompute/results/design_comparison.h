// Design variants compared: what report.json says about each variant's felt-stiffness map against the
// base design's (docs/precompute.md, "Design variants"), and about the re-meshing noise of that
// comparison. Plain records, no FE headers; filled by pipeline/design_comparison.h's
// compare_felt_stiffness, over mrt's compare_maps (mrt/map_comparison.h).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace modal_haptics
{
  // A scene's felt-stiffness map on its display surface: each vertex's value from the space whose
  // region holds it (the one a single hand pressing there is felt in).
  struct FeltStiffnessMap
  {
    std::vector<double>        vertices;  // 3 per vertex [m]
    std::vector<std::uint32_t> triangles; // 3 per triangle
    std::vector<double>        stiffness; // per vertex [N/m]; 0: not computed
    std::vector<unsigned int>  region;    // per vertex: the space whose region holds it (0: global)
    std::vector<std::string>   region_names; // per space
  };

  // One of the largest differences of a map against the base's.
  struct StiffnessDifference
  {
    std::uint32_t         vertex = 0; // of the base's display surface
    std::array<double, 3> position_m{};
    double                base_n_per_m = 0., variant_n_per_m = 0.;
    double                percent      = 0.; // 100 (variant - base) / base
    double                match_distance_m = 0.;
    bool                  beyond_noise = false;
  };

  // The % differences over some compared vertices (all, or one region's) against their floor.
  struct DifferenceFigures
  {
    std::string name;              // the region's ("" for all)
    std::size_t compared_vertices = 0;
    double      median_percent = 0., p95_abs_percent = 0., max_abs_percent = 0.;
    double      noise_floor_percent = 0.; // the floor these vertices were judged by
    std::size_t beyond_noise_vertices = 0;
    // "none" (no vertex beyond the floor), "stiffer" or "softer" (every one beyond it), or "mixed".
    std::string verdict;
  };

  // One map read at the base's display vertices (mrt::compare_maps with the base as A).
  struct MapComparisonRecord
  {
    std::string rule;             // "identity" or "closest point"
    std::size_t base_vertices = 0;
    double      max_match_distance_m = 0., p95_match_distance_m = 0.;
    double      ratio_min = 0., ratio_median = 0., ratio_max = 0.; // variant / base
    DifferenceFigures              all;     // every compared vertex, each judged by its region's floor
    std::vector<DifferenceFigures> regions; // per region of the base's display surface
    std::vector<StiffnessDifference> largest;
  };

  struct VariantComparison
  {
    std::string                                      name, folder;
    std::vector<std::pair<std::string, std::string>> overrides; // entry, value
    bool                                             meshes_reused = false; // the base's, by the mesh cache
    double                                           seconds = 0.; // its whole precompute
    MapComparisonRecord                              map;
  };

  // The re-meshing noise: the base meshed again with its mesh sizes times mesh_scale, compared with
  // the base by the same rule; in each region its 95th percentile of |%| is the floor at or below
  // which a variant's difference found by that rule is noise.
  struct NoiseFloor
  {
    bool                measured = false;
    double              mesh_scale = 0.;
    std::string         folder;
    double              seconds = 0.;
    MapComparisonRecord map;
    // Per region (space index); empty when not measured.
    std::vector<double> floors_percent() const
    {
      std::vector<double> floors;
      for (const auto &region : map.regions)
        floors.push_back(region.p95_abs_percent);
      return floors;
    }
  };

  // What a run's report.json says about design variants: the base's holds the comparisons; a
  // variant's names itself and its overrides. Empty for a scene without variants.
  struct DesignRecord
  {
    std::string                                      variant_name; // a variant's own run ("" for the base)
    std::vector<std::pair<std::string, std::string>> overrides;
    std::string                                      base_folder;
    std::vector<VariantComparison>                   variants; // the base's run
    NoiseFloor                                       noise_floor;

    bool empty() const { return variant_name.empty() && variants.empty() && !noise_floor.measured; }
  };

} // namespace modal_haptics
