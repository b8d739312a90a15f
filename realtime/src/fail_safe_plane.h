// The fail-safe plane (modalrt.h, the fail-safe rule): while the device's input is rejected or
// missing, the last safe force is not held whatever the hand does. It comes from a spring plane held
// where the hand was at the last accepted tick, across the direction of that force, at the device's
// stable stiffness: a hand that withdraws along the force is given at most the energy F^2 / (2 k) a
// real surface would return, and a hand that presses on never gets more than the last safe force.
// Where the hand is unknown (a missing input, or its own position absurd), it is taken to have moved
// on at its last accepted velocity. The plane's share of the force changes by at most the rate limit
// per tick, so a glitch of the input is no step. Impedance only; in the part's units.
#pragma once

#include "allocator.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  class FailSafePlane
  {
  public:
    // `stiffness` [N/m] and `rate_limit` [N per tick] in the part's units.
    void setup(std::uint32_t hips, double stiffness, double rate_limit, double time_step);
    // After an accepted tick: impedance remembers where the hands are; admittance has no plane.
    void remember(const modalrt_hip_input *inputs, std::uint32_t count, bool impedance) noexcept;
    void forget() noexcept { known_ = false; }
    // The first tick of a fail-safe run: every plane gives the whole last safe force.
    void begin_run() noexcept;
    // The share (1 .. 0) of HIP `hip`'s last safe force `force` [N] that its plane gives at fail-safe
    // tick `n` of the run, the hand at `hand` [m] (null: unknown).
    double share(std::uint32_t hip, const double force[3], const double *hand, std::uint64_t n) noexcept;

  private:
    bool           known_ = false;
    double         stiffness_ = 0.0, rate_limit_ = 0.0, time_step_ = 1e-3;
    Vector<double> hands_;  // 6 per HIP: position [m], velocity [m/s] at the last accepted tick, world
    Vector<double> shares_; // per HIP: the plane's share at the last fail-safe tick
  };
} // namespace modalrt
