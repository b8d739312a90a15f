// Exact zero-order-hold integration of the modal oscillators
//     q'' + 2 zeta omega q' + omega^2 q = f      (mass-normalized modes, f = modal force)
// Over one tick T with f held constant, the state x = (q, q') moves by the exact 2x2 transition
// x' = exp(A T) x + (int_0^T exp(A s) ds) b f. It is stored in increment form,
//     q' = q + (d11 q + a12 v + g1 f),   v' = v + (a21 q + d22 v + g2 f),
// with d11 = -omega^2 g1, a21 = -omega^2 a12, g2 = a12, d22 = d11 - 2 zeta omega a12 (identities of
// exp(A T) for a 2x2 companion matrix). Consequences: the fixed point under a constant f is exactly
// q = f / omega^2, v = 0 for every T (static gain 1/omega^2 by construction, not by accuracy);
// increments keep their relative precision when a mode barely moves in one tick; omega = 0 gives
// the double integrator; any T is stable.
#pragma once

#include "allocator.h"

#include <cmath>
#include <cstdint>
#include <vector>

namespace modalrt
{
  // A state or force component below this is flushed to zero: a decaying mode would otherwise
  // reach denormal numbers, which cost ~100 cycles per operation on x86. Coefficients are flushed
  // at the same threshold, so every product in a tick stays above 1e-300 (normal).
  constexpr double flush_threshold = 1e-150;

  inline double flush(double x) { return std::fabs(x) < flush_threshold ? 0.0 : x; }

  struct ModeStep
  {
    double d11, a12, a21, d22, g1, g2;
  };

  // Coefficients of one mode: lambda = omega^2 [rad^2/s^2], zeta [-], T [s].
  ModeStep discretize_mode(double lambda, double zeta, double T);

  // The coefficients of a whole space as arrays (structure of arrays: the tick loop vectorizes).
  class ModalIntegrator
  {
  public:
    // Allocates; never called in a tick.
    void setup(const double *eigenvalues, const double *damping_ratios, std::uint32_t r, double T);

    std::uint32_t mode_count() const { return std::uint32_t(d11_.size()); }
    const double *g1() const { return g1_.data(); } // displacement per unit modal force over a tick
    const double *g2() const { return g2_.data(); } // velocity per unit modal force over a tick

    // One tick in place under the modal forces f (r values).
    void step(double *q, double *v, const double *f) const;
    // One tick from (q, v) into (q_out, v_out), the inputs unchanged.
    void step_to(const double *q, const double *v, const double *f, double *q_out, double *v_out) const;

  private:
    modalrt::Vector<double> d11_, a12_, a21_, d22_, g1_, g2_;
  };
} // namespace modalrt
