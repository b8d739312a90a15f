// One modal space: a scenario's mesh, its stiffness and mass, its lowest modes, and everything
// the kernel needs of it on the scene's display surface (modes, contact blocks, static correction,
// participation factors), checked against full static FE.
#pragma once

#include "parameters/scene_parameters.h"
#include "results/space_result.h"
#include "scene/display_surface.h"

#include <deal.II/base/timer.h>

#include <string>

namespace modal_haptics
{
  // Runs the whole pipeline of one space: read mesh, assemble, eigensolve, select, interpolate on
  // the display surface, static correction, validation, VTU output into vtu_file (none if empty).
  ModalSpaceResult compute_modal_space(const SceneParameters &scene,
                                       const ContactSurface  &display,
                                       const SpaceTask       &task,
                                       const std::string     &vtu_file,
                                       dealii::TimerOutput   &timer,
                                       bool                   verbose);
} // namespace modal_haptics
