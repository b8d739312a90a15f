// Meshes shared between scenes of one part: a design variant whose meshing inputs are its base's
// (a variant of the material, of the supports) takes the base's meshes instead of meshing again, so
// that its display surface is the base's vertex for vertex (gmsh gives another mesh of the same
// inputs on another run) and its map compares with the base's by identity. Plain C++17.
#pragma once

#include "scene_mesher.h"

#include <string>
#include <vector>

namespace modal_haptics::meshing
{
  // Copies into output_directory, with its cache key, each mesh of source_directory (the scenarios'
  // and the display surface) whose key is the one this scene's mesh needs, unless output_directory
  // holds an up-to-date one already; mesh_scene() then reuses it. Returns how many were copied.
  // Throws MeshingError when a copy fails or an input is wrong (as mesh_scene).
  unsigned int adopt_meshes(const MeshingSettings &settings, const std::vector<VolumeOfInterest> &volumes_of_interest,
                            const std::string &source_directory, const std::string &output_directory,
                            bool verbose = true);
} // namespace modal_haptics::meshing
