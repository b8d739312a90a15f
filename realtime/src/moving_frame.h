// The moving frame: the part's body frame carried in the world. Inputs come in world coordinates and
// are taken into the body frame; the frame's acceleration drives the modes through PARTICIPATION.
#pragma once

#include "basis.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  // Pose and motion of the body frame, as the tick uses it.
  struct Frame
  {
    double position[3]    = {0.0, 0.0, 0.0};
    double orientation[4] = {1.0, 0.0, 0.0, 0.0};
    double rotation[9]    = {1, 0, 0, 0, 1, 0, 0, 0, 1}; // row-major, body to world
    double linear_velocity[3]  = {0.0, 0.0, 0.0};
    double angular_velocity[3] = {0.0, 0.0, 0.0};
    double body_acceleration[6] = {0, 0, 0, 0, 0, 0}; // centre-of-mass acceleration and angular
                                                       // acceleration in body coordinates: the
                                                       // column vector that PARTICIPATION multiplies
    bool moving = false; // any non-zero velocity or acceleration
  };

  // A HIP's input in body coordinates.
  struct BodyInput
  {
    double x[3], v[3], force[3];
  };

  // The frame given by `state` (modalrt_kernel_set_frame), its centre of mass at `centre_of_mass`
  // (body, [m]); false, `frame` unchanged, when `state` is not finite, its quaternion is not near
  // unit length, or it is beyond the definition's workspace_radius, max_input_velocity or
  // max_frame_acceleration.
  bool set_frame_state(Frame &frame, const modalrt_frame_state &state, const modalrt_kernel_def &def,
                       const double centre_of_mass[3]) noexcept;

  // The `count` inputs in the body frame (velocities less the frame's own motion at each point).
  void to_body(const Frame &frame, const modalrt_hip_input *inputs, std::uint32_t count, BodyInput *body) noexcept;

  // f = -Gamma a (space.mode_count values): the frame's acceleration seen by the modes.
  void frame_modal_force(const Frame &frame, const ModalSpace &space, double *f) noexcept;
} // namespace modalrt
