// The contact patch's profile, a contract of the .mrt format (docs/basis-format.md, PATCH): a contact
// at a display vertex spreads its load, and its static correction is drawn, with the weight
// (1 - (d / rho)^2)^2 at distance d from the vertex within the patch radius rho, 1 at the vertex and
// smooth to 0 at the rim. The precompute builds the patches with it and the kernel draws the
// correction with it, so both stages take it from here.
#pragma once

namespace mrt
{
  // The profile at the distance s = d / rho in patch radii (0 from s = 1 on).
  inline double patch_profile(double s)
  {
    const double t = 1.0 - s * s;
    return s < 1.0 ? t * t : 0.0;
  }
} // namespace mrt
