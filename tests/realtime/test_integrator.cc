// The exact zero-order-hold integrator of one mode: static gain, energy, omega = 0, damped cases
// against their analytic solutions, stability over dt, denormal flushing, and the coefficients
// against an independent long-double matrix exponential.
#include "modal_integrator.h"
#include "test_support.h"

#include <cmath>

using modalrt::discretize_mode;
using modalrt::ModeStep;

namespace
{
  struct State
  {
    double q, v;
  };

  State step(const ModeStep &s, State x, double f)
  {
    const double qn = x.q + (s.d11 * x.q + s.a12 * x.v + s.g1 * f);
    const double vn = x.v + (s.a21 * x.q + s.d22 * x.v + s.g2 * f);
    return {modalrt::flush(qn), modalrt::flush(vn)};
  }

  // Static gain 1/omega^2: the equilibrium q = f / omega^2 is a fixed point for every dt and
  // damping (undamped modes included, which never settle), and damped modes converge to it.
  void static_gain()
  {
    for (double lambda : {1e-2, 1.0, 3.7e3, 1e6, 1e10})
      for (double zeta : {0.0, 0.02, 0.7, 1.0 - 1e-9, 1.0, 1.0 + 1e-9, 5.0, 1e3})
        for (double T : {1e-6, 1e-3, 0.1})
          {
            const ModeStep s = discretize_mode(lambda, zeta, T);
            const double   f = 2.5, q_static = f / lambda;
            const State    x = step(s, {q_static, 0.0}, f);
            ENSURE_RELATIVE(x.q, q_static, 1e-12);
            ENSURE(std::fabs(x.v) <= 1e-12 * std::fabs(q_static) * std::sqrt(lambda));
          }
    const ModeStep s = discretize_mode(1e4, 0.1, 1e-3);
    State          x{0.0, 0.0};
    for (int n = 0; n < 20000; ++n)
      x = step(s, x, 3.0);
    ENSURE_RELATIVE(x.q, 3.0 / 1e4, 1e-12);
  }

  // An undamped mode keeps its energy over a million ticks and its phase.
  void undamped_energy()
  {
    const double   omega = 2 * 3.14159265358979323846 * 50.0, T = 1e-3;
    const ModeStep s     = discretize_mode(omega * omega, 0.0, T);
    State          x{1e-3, 0.0};
    const double   e0 = 0.5 * x.v * x.v + 0.5 * omega * omega * x.q * x.q;
    for (int n = 0; n < 1000000; ++n)
      x = step(s, x, 0.0);
    const double e = 0.5 * x.v * x.v + 0.5 * omega * omega * x.q * x.q;
    ENSURE_RELATIVE(e, e0, 1e-9);
    ENSURE_NEAR(x.q, 1e-3 * std::cos(omega * 1e6 * T), 1e-9);
  }

  // omega = 0: the double integrator q = q0 + v0 t + f t^2 / 2, exactly.
  void double_integrator()
  {
    for (double T : {1e-6, 1e-3, 0.1})
      {
        const ModeStep s = discretize_mode(0.0, 0.3, T);
        ENSURE(s.d11 == 0.0 && s.a21 == 0.0 && s.d22 == 0.0);
        ENSURE_RELATIVE(s.a12, T, 1e-15);
        ENSURE_RELATIVE(s.g1, T * T / 2, 1e-15);
        State x{0.1, -0.2};
        for (int n = 0; n < 1000; ++n)
          x = step(s, x, 0.5);
        const double t = 1000 * T;
        ENSURE_RELATIVE(x.q, 0.1 - 0.2 * t + 0.25 * t * t, 1e-11);
        ENSURE_RELATIVE(x.v, -0.2 + 0.5 * t, 1e-11);
      }
  }

  // Step responses from rest against the analytic solutions.
  void damped_against_analytic()
  {
    const double omega = 40.0, T = 1e-3, f = 7.0;
    {
      const ModeStep s = discretize_mode(omega * omega, 1.0, T);
      State          x{0.0, 0.0};
      for (int n = 1; n <= 300; ++n)
        {
          x              = step(s, x, f);
          const double t = n * T;
          ENSURE_NEAR(x.q, f / (omega * omega) * (1 - std::exp(-omega * t) * (1 + omega * t)), 1e-13 * f / (omega * omega));
        }
    }
    for (double zeta : {1.5, 20.0})
      {
        const double   root = std::sqrt(zeta * zeta - 1), p1 = -omega * (zeta - root), p2 = -omega * (zeta + root);
        const ModeStep s    = discretize_mode(omega * omega, zeta, T);
        State          x{0.0, 0.0};
        for (int n = 1; n <= 300; ++n)
          {
            x              = step(s, x, f);
            const double t = n * T;
            const double q = f / (omega * omega) * (1 - (p2 * std::exp(p1 * t) - p1 * std::exp(p2 * t)) / (p2 - p1));
            ENSURE_NEAR(x.q, q, 1e-12 * f / (omega * omega));
          }
      }
    // Free response of an under-damped mode.
    const double   zeta = 0.05, wd = omega * std::sqrt(1 - zeta * zeta);
    const ModeStep s    = discretize_mode(omega * omega, zeta, T);
    State          x{1.0, 0.0};
    for (int n = 1; n <= 500; ++n)
      {
        x              = step(s, x, 0.0);
        const double t = n * T;
        ENSURE_NEAR(x.q, std::exp(-zeta * omega * t) * (std::cos(wd * t) + zeta * omega / wd * std::sin(wd * t)), 1e-13);
      }
  }

  // Near critical damping the coefficients are continuous (no cancellation on either side).
  void near_critical_continuity()
  {
    for (double T : {1e-5, 1e-3, 0.05})
      {
        const ModeStep c = discretize_mode(1e4, 1.0, T);
        for (double zeta : {1.0 - 1e-12, 1.0 - 1e-7, 1.0 + 1e-12, 1.0 + 1e-7})
          {
            const ModeStep s = discretize_mode(1e4, zeta, T);
            // The coefficients move by O(omega T) relative per unit of zeta; a cancellation would
            // show up as errors of order eps / |zeta - 1|, far above this.
            const double tol = 10.0 * (1.0 + 100.0 * T) * std::fabs(zeta - 1.0) + 1e-14;
            ENSURE_RELATIVE(s.a12, c.a12, tol);
            ENSURE_RELATIVE(s.g1, c.g1, tol);
            ENSURE_RELATIVE(s.d11, c.d11, tol);
            ENSURE_NEAR(s.d22, c.d22, tol * std::fabs(c.d22) + 1e-15);
          }
      }
  }

  // Any dt from 1e-6 to 0.1 s: finite coefficients, spectral radius <= 1, bounded runs.
  void stable_over_dt()
  {
    for (double lambda : {0.0, 1.0, 1e4, 1e8, 1e12})
      for (double zeta : {0.0, 0.01, 0.5, 1.0, 2.0, 100.0})
        for (double T = 1e-6; T <= 0.1 * 1.0001; T *= std::sqrt(10.0))
          {
            const ModeStep s = discretize_mode(lambda, zeta, T);
            ENSURE(std::isfinite(s.d11) && std::isfinite(s.a12) && std::isfinite(s.a21) && std::isfinite(s.d22) &&
                   std::isfinite(s.g1) && std::isfinite(s.g2));
            if (lambda == 0.0)
              continue; // a double integrator has the double eigenvalue 1
            const double tr = 2 + s.d11 + s.d22, det = (1 + s.d11) * (1 + s.d22) - s.a12 * s.a21;
            const double disc = tr * tr / 4 - det;
            const double rho  = disc >= 0 ? std::fabs(tr / 2) + std::sqrt(disc) : std::sqrt(std::fabs(det));
            ENSURE(rho <= 1.0 + 1e-12);
            // Energy in (omega q, v) never grows for a damped mode.
            State        x{1.0, 0.0};
            const double e0 = lambda;
            double       e  = e0;
            for (int n = 0; n < 1000; ++n)
              {
                x = step(s, x, 0.0);
                e = lambda * x.q * x.q + x.v * x.v;
              }
            ENSURE(e <= e0 * (1 + 1e-9));
          }
  }

  // A decaying mode ends at exactly zero and never passes through denormal numbers.
  void denormals_flushed()
  {
    const ModeStep s = discretize_mode(1e6, 0.5, 1e-3);
    State          x{1.0, 1.0};
    bool           denormal = false;
    for (int n = 0; n < 20000; ++n)
      {
        x = step(s, x, 0.0);
        denormal = denormal || std::fpclassify(x.q) == FP_SUBNORMAL || std::fpclassify(x.v) == FP_SUBNORMAL;
      }
    ENSURE(!denormal);
    ENSURE(x.q == 0.0 && x.v == 0.0);
  }

  // Coefficients against exp([[A, b], [0, 0]] T) in long double (Taylor series on a scaled matrix,
  // squaring that tracks E - I so that the increments d11, d22 keep their precision).
  void against_matrix_exponential()
  {
    using L = long double;
    double worst = 0.0;
    for (double lambda : {1e-6, 1.0, 1e2, 4e4, 1e6, 1e8})
      for (double zeta : {0.0, 0.01, 0.5, 0.999999, 1.0, 1.000001, 1.5, 10.0, 1000.0})
        for (double T : {1e-6, 1e-4, 1e-3, 1e-2})
          {
            const L w = std::sqrt(L(lambda));
            if (double(w) * T * (1 + 2 * zeta) > 30)
              continue; // keep the reference itself well conditioned
            L   X[3][3] = {{0, L(T), 0}, {-L(lambda) * T, -2 * L(zeta) * w * T, L(T)}, {0, 0, 0}};
            int squarings = 0;
            for (L size = std::fabs(X[1][0]) + std::fabs(X[1][1]) + 2 * T; size > 0.01; size /= 2)
              ++squarings;
            for (auto &row : X)
              for (L &x : row)
                x = std::ldexp(x, -squarings);
            L D[3][3] = {}, P[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
            for (int k = 1; k < 30; ++k)
              {
                L Q[3][3] = {};
                for (int i = 0; i < 3; ++i)
                  for (int j = 0; j < 3; ++j)
                    for (int m = 0; m < 3; ++m)
                      Q[i][j] += P[i][m] * X[m][j] / k;
                for (int i = 0; i < 3; ++i)
                  for (int j = 0; j < 3; ++j)
                    D[i][j] += (P[i][j] = Q[i][j]);
              }
            for (int k = 0; k < squarings; ++k)
              {
                L D2[3][3] = {};
                for (int i = 0; i < 3; ++i)
                  for (int j = 0; j < 3; ++j)
                    for (int m = 0; m < 3; ++m)
                      D2[i][j] += D[i][m] * D[m][j];
                for (int i = 0; i < 3; ++i)
                  for (int j = 0; j < 3; ++j)
                    D[i][j] = 2 * D[i][j] + D2[i][j];
              }
            const ModeStep s      = discretize_mode(lambda, zeta, T);
            const double   got[6] = {s.d11, s.a12, s.a21, s.d22, s.g1, s.g2};
            const L        ref[6] = {D[0][0], D[0][1], D[1][0], D[1][1], D[0][2], D[1][2]};
            for (int k = 0; k < 6; ++k)
              if (std::fabs(ref[k]) > 1e-280)
                worst = std::max(worst, double(std::fabs((got[k] - ref[k]) / ref[k])));
          }
    std::printf("  coefficients vs long-double matrix exponential: max relative error %.2e\n", worst);
    ENSURE(worst <= 1e-13);
  }
} // namespace

int main()
{
  static_gain();
  undamped_energy();
  double_integrator();
  damped_against_analytic();
  near_critical_continuity();
  stable_over_dt();
  denormals_flushed();
  against_matrix_exponential();
  return test::finish("test_integrator");
}
