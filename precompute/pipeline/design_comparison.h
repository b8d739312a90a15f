// A variant's felt-stiffness map against the base's, by mrt's compare_maps (mrt/map_comparison.h:
// the one matching rule of the tools and the precompute), as report.json's record. No deal.II.
#pragma once

#include "results/design_comparison.h"

#include <cstddef>
#include <vector>

namespace modal_haptics
{
  // The floor of a comparison by the identity rule: the same meshes, so no re-meshing noise; only the
  // static solves' precision (the corrected contacts agree with full FE to 1e-8).
  constexpr double identity_noise_floor_percent = 1e-6;

  // Compares 'variant' with 'base' (mrt::compare_maps): its rule, match, ratios, largest differences,
  // and the % differences over all compared vertices and per region of the base. A vertex's
  // difference is noise at or below its region's floor: floors_percent[region] under the
  // closest-point rule (empty: 0), identity_noise_floor_percent under the identity rule.
  MapComparisonRecord compare_felt_stiffness(const FeltStiffnessMap &base, const FeltStiffnessMap &variant,
                                             const std::vector<double> &floors_percent,
                                             std::size_t largest_count = 10);
} // namespace modal_haptics
