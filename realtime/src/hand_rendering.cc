// What the device renders (kernel.h): the kernel's ticks in the device's units around its ticks in
// the part's (kernel.cc), through the haptic mapping (haptic_mapping.h); the stable-stiffness limit
// (coupling.h), the passivity controller and the force limit at the hand.
#include "kernel.h"

#include "coupling.h"

#include "vector3.h"

#include <algorithm>
#include <cmath>

using namespace modalrt;

// =================================================================================================
// The ticks in the device's units
// =================================================================================================
int modalrt_kernel::tick(const modalrt_hip_input *inputs, std::uint32_t count, modalrt_hip_output *outputs,
                         bool impedance) noexcept
{
  const int status = tick_in_part_units(mapping_.to_part(inputs, count), count, outputs, impedance);
  if (status < 0)
    return status;
  const std::uint32_t n = std::min(count, def.hip_capacity);
  mapping_.to_device(outputs, n);
  if (status == MODALRT_OK && impedance)
    render_at_hand(inputs, n, outputs);
  else
    passivity_.skip();
  return status;
}

int modalrt_kernel::tick_missing(std::uint32_t count, modalrt_hip_output *outputs) noexcept
{
  const int status = tick_missing_in_part_units(count, outputs);
  if (status >= 0)
    mapping_.to_device(outputs, count);
  passivity_.skip();
  return status;
}

// What the device renders: the stable-stiffness limit (with a scale), the passivity controller,
// the force limit; then the kernel's record of the force commanded follows what was sent, so that
// a ramp of its own (a release) starts from it.
void modalrt_kernel::render_at_hand(const modalrt_hip_input *inputs, std::uint32_t count,
                                    modalrt_hip_output *outputs) noexcept
{
  for (std::uint32_t h = 0; h < count && mapping_.scaled(); ++h)
    if (outputs[h].in_contact)
      limit_to_stable_stiffness(mapping_, frame_, contacts_[h], body_inputs_[h], outputs[h]);
  // While the part's frame moves (a carried part), the session moves the part and the hands with it:
  // that energy is the carry's, not the coupling's, and the observer cannot tell the two apart, so
  // it watches only the periods of a still frame (the controller would otherwise damp the carry).
  if (frame_.moving)
    passivity_.skip();
  else
    passivity_.control(inputs, outputs, count, stats);
  for (std::uint32_t h = 0; h < count; ++h)
    {
      double *F = outputs[h].force;
      const double size = norm3(F);
      if (size > mapping_.max_force())
        {
          for (int d = 0; d < 3; ++d)
            F[d] *= mapping_.max_force() / size;
          outputs[h].flags |= MODALRT_HIP_FORCE_CLAMPED;
        }
      if (outputs[h].flags & MODALRT_HIP_BEYOND_RANGE)
        ++stats.beyond_range_ticks;
      mapping_.force_to_part(F, &commanded_[3 * std::size_t(h)]);
      std::copy_n(&commanded_[3 * std::size_t(h)], 3, last_outputs_[h].force);
    }
}
