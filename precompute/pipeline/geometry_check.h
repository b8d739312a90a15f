// Before anything is meshed (every run, and all of --validate): the geometry loaded without meshing
// and checked against the scene's .prm, so that what would fail after minutes of meshing fails in a
// second, and what looks wrong is said while it is cheap to fix.
#pragma once

#include "parameters/scene_parameters.h"

namespace modal_haptics
{
  // Loads the geometry (meshing::inspect_geometry: its declared unit, every named group and
  // selection) and checks what depends on the length unit: the part's size and mass, the mesh sizes
  // and the contact patch against its size (a coarse size larger than the part is refused, the
  // rest warned about). With 'predict_free_motions' (--validate) the rigid-body motions the supports
  // would leave free are predicted from points on what each selection meets, and refused as the run
  // would refuse them. The summary ([geometry] lines) and the warnings are printed when 'print'.
  void check_geometry(const SceneParameters &scene, bool print, bool predict_free_motions);
} // namespace modal_haptics
