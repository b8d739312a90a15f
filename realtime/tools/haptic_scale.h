// A device profile on the command line (`--device NAME`, `--profile NAME`, `--haptic-scale S`):
// the kernel's device spec from the profile, and on an impedance profile the one haptic scale of the
// session: given, or so that the stiffest part of the band (the 95th percentile of the scene's
// felt-stiffness map, stiffness_band_top) is rendered at the profile's stable stiffness.
#pragma once

#include <modalrt/modalrt.h>

#include <string>

namespace modalrt_tool
{
  constexpr double band_percentile = 95.0; // [%] of the felt-stiffness map's positive values

  // The map's percentile `band_percentile` over every display vertex (each in its region's space)
  // [N/m]; 0 without a map.
  double stiffness_band_top(const modalrt_basis *basis);

  // Puts profile `name` into `def` (device spec and, impedance, haptic_scale: `scale` if > 0, else
  // max_stiffness / stiffness_band_top). false and `error` for an unknown name, an admittance profile
  // in impedance mode or an impedance profile in admittance mode, or no band to scale to.
  bool apply_device_profile(const std::string &name, double scale, bool impedance, const modalrt_basis *basis,
                            modalrt_kernel_def &def, std::string &error);

  // "1 N/mm at the hand = 40 N/mm of part (touch: ...)", or "" without a scale.
  std::string haptic_scale_line(const std::string &profile, const modalrt_haptic_mapping &mapping,
                                const modalrt_kernel_def &def);
} // namespace modalrt_tool
