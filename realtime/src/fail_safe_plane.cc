// The fail-safe plane (fail_safe_plane.h).
#include "fail_safe_plane.h"

#include "vector3.h"

#include <algorithm>

namespace modalrt
{
  void FailSafePlane::setup(std::uint32_t hips, double stiffness, double rate_limit, double time_step)
  {
    stiffness_  = stiffness;
    rate_limit_ = rate_limit;
    time_step_  = time_step;
    hands_.assign(6 * std::size_t(hips), 0.0);
    shares_.assign(hips, 1.0);
    known_ = false;
  }

  void FailSafePlane::remember(const modalrt_hip_input *inputs, std::uint32_t count, bool impedance) noexcept
  {
    known_ = impedance;
    if (!impedance)
      return;
    for (std::uint32_t h = 0; h < count && h < shares_.size(); ++h)
      {
        std::copy_n(inputs[h].position, 3, &hands_[6 * std::size_t(h)]);
        std::copy_n(inputs[h].velocity, 3, &hands_[6 * std::size_t(h) + 3]);
      }
  }

  void FailSafePlane::begin_run() noexcept { std::fill(shares_.begin(), shares_.end(), 1.0); }

  double FailSafePlane::share(std::uint32_t hip, const double force[3], const double *hand, std::uint64_t n) noexcept
  {
    const double size = norm3(force);
    if (!known_ || size == 0.0 || hip >= shares_.size())
      return 1.0;
    const double *last = &hands_[6 * std::size_t(hip)], *velocity = last + 3;
    double        moved[3];
    for (int d = 0; d < 3; ++d)
      moved[d] = hand ? hand[d] - last[d] : velocity[d] * double(n) * time_step_;
    const double withdrawn = dot3(moved, force) / size; // along the force: out of the part
    const double target    = std::clamp(1.0 - stiffness_ * withdrawn / size, 0.0, 1.0);
    const double most      = rate_limit_ / size; // the share's change at the rate limit
    double      &current   = shares_[hip];
    current                = std::clamp(target, current - most, current + most);
    return current;
  }
} // namespace modalrt
