// The default device both stages assume where the user names none: the kernel's default device spec
// (modalrt_device_default_def) and the force up to which the precompute's validity analysis loads a
// contact ('Contact/Force limit'), so that a validity map covers every force the default device
// renders.
#pragma once

namespace mrt
{
  constexpr double default_max_force = 10.0; // [N]
} // namespace mrt
