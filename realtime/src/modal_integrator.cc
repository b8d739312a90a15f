#include "modal_integrator.h"

#include <algorithm>

namespace modalrt
{
  namespace
  {
    // With X = A T, everything reduces to two divided differences over the eigenvalues x1, x2 of X
    // (x1,2 = m +- h, m = -zeta omega T, h^2 = (zeta^2 - 1) (omega T)^2, x1 x2 = (omega T)^2):
    //   exp(X)   = alpha0 I + beta0 X,   beta0 = exp[x1, x2]
    //   phi1(X)  = alpha1 I + beta1 X,   beta1 = E1[x1, x2],   E1(x) = (e^x - 1) / x
    // and a12 = T beta0, g1 = T^2 beta1. Each is evaluated where it has no cancellation.

    double e1(double x) { return x == 0.0 ? 1.0 : std::expm1(x) / x; }

    // exp[x1, x2] = e^m sinh(h) / h, continued to complex h (sin) and to large h (no overflow).
    double exp_divided_difference(double m, double h2, double w, double zeta)
    {
      if (h2 < 0.0)
        {
          const double theta = std::sqrt(-h2);
          return std::exp(m) * std::sin(theta) / theta;
        }
      const double h = std::sqrt(h2);
      if (h == 0.0)
        return std::exp(m);
      if (h < 20.0)
        return std::exp(m) * std::sinh(h) / h;
      // e^m sinh h = e^(x1) (1 - e^(-2h)) / 2 with x1 = m + h computed without cancellation.
      const double x1 = -w / (zeta + std::sqrt((zeta - 1.0) * (zeta + 1.0)));
      return std::exp(x1) * -std::expm1(-2.0 * h) / (2.0 * h);
    }

    // E1[x1, x2] as a power series in the symmetric functions s = x1 + x2, p = x1 x2:
    // E1[x1, x2] = sum_k c_k / (k + 1)!, c_1 = 1, c_2 = s, c_(k+1) = s c_k - p c_(k-1).
    // Used when |x1|, |x2| <= 1, where it converges fast and has no cancellation to speak of.
    double e1_divided_difference_series(double s, double p)
    {
      double c_prev = 0.0, c = 1.0, factorial = 2.0, sum = 0.5;
      for (int k = 1; k < 40; ++k)
        {
          const double c_next = s * c - p * c_prev;
          c_prev              = c;
          c                   = c_next;
          factorial *= double(k + 2);
          const double term = c / factorial;
          sum += term;
          // Both of the last two c_k bound the next ones (|s| <= 2, |p| <= 1), and one of them
          // may vanish (s = 0 for an undamped mode), so the test looks at both.
          if ((std::fabs(c) + std::fabs(c_prev)) / factorial <= 1e-18 * std::fabs(sum))
            break;
        }
      return sum;
    }

    double e1_divided_difference(double m, double h2, double w, double zeta)
    {
      if (std::fabs(m) + std::sqrt(std::fabs(h2)) <= 1.0)
        return e1_divided_difference_series(2.0 * m, w * w);
      if (h2 > 0.0 && std::sqrt(h2) >= 0.25)
        {
          // Real, well separated eigenvalues (over-damped): the direct quotient is accurate.
          const double root = std::sqrt((zeta - 1.0) * (zeta + 1.0));
          const double x1 = -w / (zeta + root), x2 = -w * (zeta + root);
          return (e1(x1) - e1(x2)) / (2.0 * std::sqrt(h2));
        }
      // Complex or close eigenvalues away from 0: beta1 = (1 - alpha0) / (omega T)^2, where
      // alpha0 = e^m (cosh h - m sinh(h) / h) is not close to 1 here (|x| > 1), so 1 - alpha0 keeps
      // its precision.
      double c, shc;
      if (h2 < 0.0)
        {
          const double theta = std::sqrt(-h2);
          c                  = std::cos(theta);
          shc                = std::sin(theta) / theta;
        }
      else
        {
          const double h = std::sqrt(h2);
          c              = std::cosh(h);
          shc            = h == 0.0 ? 1.0 : std::sinh(h) / h;
        }
      const double alpha0 = std::exp(m) * (c - m * shc);
      return (1.0 - alpha0) / (w * w);
    }
  } // namespace

  ModeStep discretize_mode(double lambda, double zeta, double T)
  {
    const double omega = std::sqrt(lambda);
    const double w     = omega * T;
    const double m     = -zeta * w;
    const double h2    = (zeta - 1.0) * (zeta + 1.0) * w * w;

    ModeStep step;
    step.a12 = flush(T * exp_divided_difference(m, h2, w, zeta));
    step.g1  = flush(T * T * e1_divided_difference(m, h2, w, zeta));
    // The identities below, applied to the stored (rounded) values, are what make the static gain
    // exact: at v = 0 the q-increment vanishes iff lambda q = f.
    step.d11 = flush(-lambda * step.g1);
    step.a21 = flush(-lambda * step.a12);
    step.g2  = step.a12;
    step.d22 = flush(step.d11 - 2.0 * zeta * omega * step.a12);
    return step;
  }

  void ModalIntegrator::setup(const double *eigenvalues, const double *damping_ratios, std::uint32_t r, double T)
  {
    for (modalrt::Vector<double> *c : {&d11_, &a12_, &a21_, &d22_, &g1_, &g2_})
      c->resize(r);
    for (std::uint32_t i = 0; i < r; ++i)
      {
        const ModeStep s = discretize_mode(eigenvalues[i], damping_ratios[i], T);
        d11_[i]          = s.d11;
        a12_[i]          = s.a12;
        a21_[i]          = s.a21;
        d22_[i]          = s.d22;
        g1_[i]           = s.g1;
        g2_[i]           = s.g2;
      }
  }

  void ModalIntegrator::step_to(const double *q, const double *v, const double *f, double *q_out, double *v_out) const
  {
    const std::size_t r   = d11_.size();
    const double     *d11 = d11_.data(), *a12 = a12_.data(), *a21 = a21_.data(), *d22 = d22_.data();
    const double     *g1 = g1_.data(), *g2 = g2_.data();
    // Modes are independent: each lane reads and writes only index i (q_out may be q).
#pragma omp simd
    for (std::size_t i = 0; i < r; ++i)
      {
        const double fi = flush(f[i]), qi = q[i], vi = v[i];
        const double qn = qi + (d11[i] * qi + a12[i] * vi + g1[i] * fi);
        const double vn = vi + (a21[i] * qi + d22[i] * vi + g2[i] * fi);
        q_out[i]        = flush(qn);
        v_out[i]        = flush(vn);
      }
  }

  void ModalIntegrator::step(double *q, double *v, const double *f) const { step_to(q, v, f, q, v); }
} // namespace modalrt
