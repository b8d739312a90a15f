// The haptic mapping (modalrt.h, modalrt_kernel_def.haptic_scale): what the hand feels on an
// impedance device. The tick runs in the part's units; the device works in its own. A HIP's part
// position is origin + sigma x its device position; the force commanded is s / sigma x the force on
// the part, so the stiffness at the hand is s x the stiffness in the part. The part's coupling is
// made `coupling_multiple` times stiffer than the band's stiffest part (device.max_stiffness / s):
// its series share, which compresses the ratios between places, is at most 1 / (1 + multiple).
#pragma once

#include "allocator.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  constexpr double default_coupling_multiple = 200.0; // series share <= 1 / 201 = 0.5 %

  // The kernel's definition in the part's units (what the tick runs on): with a haptic scale the
  // coupling, the force limit and the rate limit as the part sees them. Checks the mapping's fields.
  modalrt_kernel_def part_side_def(const modalrt_kernel_def &def);

  // Colgate & Schenkel's sampled-passivity condition b > K T / 2 + |B| at the hand (impedance
  // devices): refuses the definition, naming the values, unless the passivity controller is on.
  void check_sampled_passivity(const modalrt_kernel_def &def);

  class HapticMapping
  {
  public:
    void setup(const modalrt_kernel_def &device_def, const modalrt_kernel_def &part_def, std::uint32_t hips);

    bool   scaled() const { return scale_ > 0.0; }
    double haptic_scale() const { return scale_; }
    double force_scale() const { return force_scale_; }   // force commanded / force on the part
    double position_scale() const { return sigma_; }      // m of part per m of device
    double stable_stiffness() const { return stable_stiffness_; } // [N/m] at the hand
    double max_force() const { return max_force_; }       // [N] at the hand
    // A stiffness at the hand [N/m] in the part's units (the hand feels s x the part's).
    double stiffness_to_part(double at_hand) const { return at_hand / (force_scale_ * sigma_); }
    void   describe(modalrt_haptic_mapping &out, const modalrt_kernel_def &part_def) const;

    // The inputs in the part's units (the same pointer when the mapping is the identity, or when
    // count exceeds the capacity: the tick refuses that itself).
    const modalrt_hip_input *to_part(const modalrt_hip_input *inputs, std::uint32_t count) noexcept;
    // Outputs from the part's units into the device's, in place.
    void to_device(modalrt_hip_output *outputs, std::uint32_t count) const noexcept;
    // A device-side force back in the part's units (what the kernel records as commanded).
    void force_to_part(const double device[3], double part[3]) const noexcept;

  private:
    bool   identity_ = true;
    double scale_ = 0.0, sigma_ = 1.0, force_scale_ = 1.0, origin_[3] = {0.0, 0.0, 0.0};
    double stable_stiffness_ = 0.0, max_force_ = 0.0;
    Vector<modalrt_hip_input> inputs_;
  };
} // namespace modalrt
