// What the device renders (kernel.h): the kernel's ticks in the device's units around its ticks in
// the part's (kernel.cc), through the haptic mapping (haptic_mapping.h); the stable-stiffness limit,
// the passivity controller and the force limit at the hand; the coupling spring of a contact.
#include "kernel.h"

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
      limit_to_stable_stiffness(h, outputs[h]);
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

// The force along the contact's outward normal is at most device.max_stiffness x the hand's travel
// into the surface at rest (device units): a part stiffer than the band is a wall at the device's
// stable stiffness. A snap contact's normal part alone is held (its lateral spring is soft, 1 % of
// the band's top). A sliding contact's whole force is scaled with its normal part: friction carries
// at most mu times the normal force that the contact transmits, and the hand feels the wall's, so
// the tangential force the cone allows falls with it; scaling both keeps the force's direction, and
// so F_t / F_n within the cone the proxy's friction held on the part, and a stuck proxy's
// tangential stiffness falls by the wall's share like the normal one (holding the normal part alone
// left the tangential force of the part's scale: F_t / F_n up to mu times the part's stiffness over
// the band's top).
void modalrt_kernel::limit_to_stable_stiffness(std::uint32_t hip, modalrt_hip_output &out) noexcept
{
  const Contact &c = contacts_[hip];
  double         offset[3], n[3];
  for (int d = 0; d < 3; ++d)
    offset[d] = body_inputs_[hip].x[d] - c.rest[d];
  rotate(frame_.rotation, c.normal, n);
  const double travel = std::max(0.0, -dot3(offset, c.normal)) / mapping_.position_scale();
  const double along  = dot3(out.force, n), limit = mapping_.stable_stiffness() * travel;
  if (along <= limit)
    return;
  if (c.proxy.active)
    for (int d = 0; d < 3; ++d)
      out.force[d] *= limit / along;
  else
    for (int d = 0; d < 3; ++d)
      out.force[d] -= (along - limit) * n[d];
  out.flags |= MODALRT_HIP_BEYOND_RANGE;
}

// The coupling spring of a contact (body frame). With a haptic scale, a snap contact's is stiff along
// the contact's normal only (coupling_stiffness, the part's units) and 1 % of the band's top stiffness
// across it: a spring as stiff in every direction would pin the contact point sideways, where the part moves
// as it bends, and the hand would feel the laterally held part, stiffer than the part pressed straight
// in (by 8 % on the tests' lattice). A sliding contact (its friction holds it sideways) and a kernel
// without a scale: coupling_stiffness in every direction.
void modalrt_kernel::set_contact_stiffness(Contact &c) const noexcept
{
  constexpr double lateral_share = 0.01; // across the normal: 1 % of the band's top
  const double K      = def.coupling_stiffness;
  const bool   normal = mapping_.scaled() && !c.proxy.active;
  const double across = normal ? lateral_share * mapping_.stable_stiffness() / mapping_.haptic_scale() : K;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c.stiffness[3 * i + j] = (i == j ? across : 0.0) + (normal ? (K - across) * c.normal[i] * c.normal[j] : 0.0);
}
