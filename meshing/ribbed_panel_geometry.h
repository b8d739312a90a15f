// Internal: the built-in default part ("builtin:ribbed_panel") built with gmsh's OpenCASCADE kernel.
#pragma once

#include "scene_mesher.h"

#include <string>

namespace modal_haptics::meshing::detail
{
  // Physical tags of the built-in part's named groups (tags are per dimension in gmsh).
  inline constexpr int part_group_tag  = 1; // volume "part"
  inline constexpr int clamp_group_tag = 1; // surface "clamp"
  inline constexpr int free_group_tag  = 2; // surface "free"

  // Throws MeshingError naming the first parameter that makes no valid part.
  void check_ribbed_panel(const RibbedPanelGeometry &geometry);

  // Builds the panel as ONE volume in the current (empty) gmsh model, synchronizes it and adds the
  // groups "part", "clamp" (top annular faces of the bosses) and "free" (every other boundary face).
  void build_ribbed_panel(const RibbedPanelGeometry &geometry);

  // Every parameter, printed exactly: the geometry's part of a cache key.
  std::string describe_ribbed_panel(const RibbedPanelGeometry &geometry);
} // namespace modal_haptics::meshing::detail
