// The passivity controller at the hand (passivity_controller.h).
#include "passivity_controller.h"

#include "vector3.h"

#include <algorithm>

namespace modalrt
{
  void PassivityController::setup(bool enabled, double time_step, double max_damping, std::uint32_t hips)
  {
    enabled_     = enabled;
    time_step_   = time_step;
    max_damping_ = max_damping;
    energy_.assign(hips, 0.0);
    position_.assign(3 * std::size_t(hips), 0.0);
    force_.assign(3 * std::size_t(hips), 0.0);
    primed_.assign(hips, 0);
  }

  void PassivityController::skip() noexcept { std::fill(primed_.begin(), primed_.end(), 0u); }

  void PassivityController::control(const modalrt_hip_input *inputs, modalrt_hip_output *outputs, std::uint32_t count,
                                    modalrt_kernel_stats &stats) noexcept
  {
    for (std::uint32_t h = 0; h < count && h < energy_.size(); ++h)
      {
        double *x = &position_[3 * std::size_t(h)], *F_last = &force_[3 * std::size_t(h)];
        double  work = 0.0;
        if (primed_[h])
          for (int d = 0; d < 3; ++d)
            work -= F_last[d] * (inputs[h].position[d] - x[d]);
        energy_[h] += work;
        stats.hand_passivity_energy += work;
        stats.min_hip_passivity_energy = std::min(stats.min_hip_passivity_energy, energy_[h]);
        modalrt_hip_output &out = outputs[h];
        const double        v2  = dot3(inputs[h].velocity, inputs[h].velocity);
        if (enabled_ && out.in_contact && energy_[h] < 0.0 && v2 > 0.0)
          {
            const double alpha = std::min(-energy_[h] / (time_step_ * v2), max_damping_);
            for (int d = 0; d < 3; ++d)
              out.force[d] -= alpha * inputs[h].velocity[d];
            out.flags |= MODALRT_HIP_PASSIVITY_DAMPED;
            stats.passivity_damping_energy += alpha * v2 * time_step_;
            stats.max_passivity_damping = std::max(stats.max_passivity_damping, alpha);
            ++stats.passivity_damped_ticks;
          }
        // The window ends where no energy is stored: out of contact, the kernel's release ramp done.
        if (!out.in_contact && norm3(out.force) == 0.0)
          energy_[h] = 0.0;
        std::copy_n(inputs[h].position, 3, x);
        std::copy_n(out.force, 3, F_last);
        primed_[h] = 1;
      }
  }
} // namespace modalrt
