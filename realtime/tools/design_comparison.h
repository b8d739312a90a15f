// `modal-rt info --basis A.mrt --compare B.mrt`: where design B's felt stiffness differs from design
// A's. Both scenes' maps (each display vertex from its region's space: scene_felt_stiffness) are
// compared by mrt::compare_maps (mrt/map_comparison.h: the matching rule, docs/accuracy.md "Two
// designs compared"), B read at A's display vertices.
#pragma once

#include <modalrt/modalrt.h>
#include <mrt/map_comparison.h>

#include <cstddef>
#include <string>

namespace modalrt_tool
{
  struct DesignComparisonOptions
  {
    std::size_t largest       = 10;  // how many of the largest |%| differences to list
    double      noise_percent = 1.0; // |B - A| / A at or below it: no difference [%]
  };

  // Loads B from `path_b` and compares its scene map with A's (already loaded from `path_a`). False,
  // with `error` naming the file, when B cannot be read or either file has no felt-stiffness map.
  // The live view's Stiffness tab shows the same comparison.
  bool compare_scene_maps(const modalrt_basis *a, const char *path_a, const char *path_b,
                          const DesignComparisonOptions &options, mrt::MapComparison &comparison, std::string &error);

  // Loads B from `path_b` and prints the comparison with A (already loaded from `path_a`). Exit
  // status 1, with a message naming the file, when B cannot be read or either file has no
  // felt-stiffness map; else 0.
  int compare_designs(const modalrt_basis *a, const char *path_a, const char *path_b,
                      const DesignComparisonOptions &options);
} // namespace modalrt_tool
