// The passivity controller at the hand (Hannaford & Ryu 2002), per HIP, in the device's units. The
// observer is the work the hand has done on the kernel over the HIP's contact (its window: from the
// contact's start until its force is back to zero after the release), E_n = E_(n-1) - F_(n-1) .
// (x_n - x_(n-1)), F the force commanded and held over the period. When E_n < 0 the kernel has given
// the hand energy; in contact, the controller then adds the damping alpha = -E_n / (T |v_n|^2), at most the
// device's max_damping, to the force of this tick (F -= alpha v_n), which dissipates the deficit over
// the next period.
#pragma once

#include "allocator.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  class PassivityController
  {
  public:
    void setup(bool enabled, double time_step, double max_damping, std::uint32_t hips);
    // After an accepted impedance tick: observes and, when enabled, damps `outputs` (device units).
    void control(const modalrt_hip_input *inputs, modalrt_hip_output *outputs, std::uint32_t count,
                 modalrt_kernel_stats &stats) noexcept;
    // A fail-safe tick: the next period is not observed.
    void skip() noexcept;

  private:
    bool   enabled_ = true;
    double time_step_ = 1e-3, max_damping_ = 0.0;
    Vector<double>        energy_, position_, force_; // per HIP: E, x_(n-1), F_(n-1)
    Vector<std::uint32_t> primed_;
  };
} // namespace modalrt
