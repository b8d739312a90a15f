// The virtual coupling of a contact (coupling.h).
#include "coupling.h"

#include "vector3.h"

#include <algorithm>

using namespace modalrt;

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
void modalrt::limit_to_stable_stiffness(const HapticMapping &mapping, const Frame &frame, const Contact &c,
                                        const BodyInput &input, modalrt_hip_output &out) noexcept
{
  double offset[3], n[3];
  for (int d = 0; d < 3; ++d)
    offset[d] = input.x[d] - c.rest[d];
  rotate(frame.rotation, c.normal, n);
  const double travel = std::max(0.0, -dot3(offset, c.normal)) / mapping.position_scale();
  const double along  = dot3(out.force, n), limit = mapping.stable_stiffness() * travel;
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
void modalrt::set_contact_stiffness(const HapticMapping &mapping, double K, Contact &c) noexcept
{
  constexpr double lateral_share = 0.01; // across the normal: 1 % of the band's top
  const bool   normal = mapping.scaled() && !c.proxy.active;
  const double across = normal ? lateral_share * mapping.stable_stiffness() / mapping.haptic_scale() : K;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c.stiffness[3 * i + j] = (i == j ? across : 0.0) + (normal ? (K - across) * c.normal[i] * c.normal[j] : 0.0);
}
