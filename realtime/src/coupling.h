// The virtual coupling between a HIP and its contact: the spring (its stiffness across and along the
// contact's normal, with or without a haptic scale) and the limit of the force along the normal to
// what the device renders stably at the hand's travel into the surface. The damper is the
// definition's coupling_damping in every direction (kernel.cc's impedance step).
#pragma once

#include "contact_state.h"
#include "haptic_mapping.h"
#include "moving_frame.h"

#include <modalrt/modalrt.h>

namespace modalrt
{
  // The coupling spring of contact c (c.stiffness, body frame) for coupling stiffness K (the part's
  // units).
  void set_contact_stiffness(const HapticMapping &mapping, double K, Contact &c) noexcept;

  // Output `out` (device units, world) of contact c, whose HIP is at `input` (body frame), with its
  // force along the contact's normal at most the stable stiffness times the hand's travel into the
  // surface at rest; flagged MODALRT_HIP_BEYOND_RANGE when held.
  void limit_to_stable_stiffness(const HapticMapping &mapping, const Frame &frame, const Contact &c,
                                 const BodyInput &input, modalrt_hip_output &out) noexcept;
} // namespace modalrt
