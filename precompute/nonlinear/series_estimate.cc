// The felt displacement's series d(F) = c1 F + c2 F^2 + c3 F^3 about the unloaded state: the forces
// where it departs from the linear compliance (series_validity_forces), and its terms at a contact
// from the stored energy's expansion along the linear response (LargeDeformationSolve's estimates).
#include "nonlinear/large_deformation_solve.h"

#include <deal.II/base/timer.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    namespace
    {
      // The least F > 0 with c3 F^2 + c2 F = rise (infinity if none), by the rounding-safe form of the roots.
      double least_positive_root(const double c3, const double c2, const double rise)
      {
        const double none = std::numeric_limits<double>::infinity();
        if (c3 == 0.)
          return c2 != 0. && rise / c2 > 0. ? rise / c2 : none;
        const double discriminant = c2 * c2 + 4. * c3 * rise;
        if (discriminant < 0.)
          return none;
        const double q     = -0.5 * (c2 + std::copysign(std::sqrt(discriminant), c2));
        double       least = none;
        for (const double root : {q / c3, q != 0. ? -rise / q : none})
          if (root > 0. && root < least)
            least = root;
        return least;
      }
    } // namespace

    std::array<double, 3> series_validity_forces(const double c1, const double c2, const double c3)
    {
      std::array<double, 3> forces;
      for (unsigned int k = 0; k < validity_departures.size(); ++k)
        {
          const double delta = validity_departures[k];
          forces[k]          = std::min(least_positive_root(c3, c2, c1 * delta / (1. - delta)),  // softening
                                        least_positive_root(c3, c2, -c1 * delta / (1. + delta))); // stiffening
        }
      return forces;
    }

    template <typename Algebra>
    double LargeDeformationSolve<Algebra>::estimate_second_order(const VectorType &u1, ValidityCurve &curve)
    {
      Timer        timer;
      double       largest_gradient = 0.;
      const double psi3             = cubic_energy(space, material, law, u1, &largest_gradient);
      curve.estimate_seconds += timer.wall_time();
      curve.estimate_exact.c2 = -3. * psi3;
      curve.estimate_exact.validity_force = series_validity_forces(curve.linear_compliance, curve.estimate_exact.c2);
      return largest_gradient > 0. ? 1e-3 / largest_gradient : curve.force_limit / 100.;
    }

    template <typename Algebra>
    typename LargeDeformationSolve<Algebra>::ResponseSamples
    LargeDeformationSolve<Algebra>::sample_along_response(const VectorType &u1, double h)
    {
      ResponseSamples samples;
      samples.even_rhs.assign(3, u1);
      for (unsigned int attempt = 0; attempt < 8 && !samples.inside; ++attempt, h /= 4.)
        samples.inside = sample_at_steps(u1, h, samples);
      return samples;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::sample_at_steps(const VectorType &u1, const double h,
                                                         ResponseSamples &samples)
    {
      samples.h = h;
      for (unsigned int i = 0; i < 3; ++i)
        {
          samples.odd_energy[i] = samples.even_energy[i] = 0.;
          samples.even_rhs[i]                            = 0.;
          for (const double sign : {1., -1.})
            {
              VectorType u(u1);
              u *= sign * (i + 1) * h;
              if (!assemble(u, 0., u1, false))
                return false;
              samples.odd_energy[i] += sign * 0.5 * energy;
              samples.even_energy[i] += 0.5 * energy;
              samples.even_rhs[i].add(0.5, rhs);
            }
        }
      return true;
    }

    // The odd part of the stored energy along t u1, o(t) = t^3 Psi3 + t^5 Psi5 + ... (the elastic
    // supports' quadratic energy cancels), at t = h and 2 h: Richardson's (32 o(h) - o(2 h)) / (24 h^3).
    template <typename Algebra>
    void LargeDeformationSolve<Algebra>::check_cubic_term(const ResponseSamples &samples, ValidityCurve &curve)
    {
      if (!samples.inside)
        return; // stays -1: not computed
      const double psi3              = -curve.estimate_exact.c2 / 3.;
      const double h                 = samples.h;
      const double finite_difference = (32. * samples.odd_energy[0] - samples.odd_energy[1]) / (24. * h * h * h);
      curve.cubic_term_check = std::abs(finite_difference - psi3) / std::max(std::abs(psi3), 1e-300);
    }

    namespace
    {
      // The weights on e(h), e(2 h), e(3 h) of the t^2 and t^4 coefficients of an even series
      // e(t) = x t^2 + y t^4 + z t^6 (+ O(t^8)): the quadratic e / s in s = (t / h)^2 through s = 1, 4, 9
      // by divided differences, applied to each unit sample.
      std::array<std::array<double, 3>, 2> even_series_weights()
      {
        std::array<std::array<double, 3>, 2> weights{};
        for (unsigned int i = 0; i < 3; ++i)
          {
            std::array<double, 3> e{};
            e[i]                 = 1.;
            const double f1 = e[0], f4 = e[1] / 4., f9 = e[2] / 9.;
            const double d1 = (f4 - f1) / 3., d2 = (f9 - f4) / 5., z = (d2 - d1) / 8., y = d1 - 5. * z;
            weights[0][i] = f1 - y - z; // x h^2
            weights[1][i] = y;          // y h^4
          }
        return weights;
      }
    } // namespace

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::estimate_third_order(const ResponseSamples &samples, ValidityCurve &curve,
                                                              VectorType &u2)
    {
      // d(F) = c1 F + c2 F^2 + c3 F^3: K u2 = -grad Psi3(u1) = -g2, K u3 = -2 B(u1, u2) - grad Psi4(u1)
      // (grad Psi3(u) = B(u, u)), and u1^T B(u1, u2) = g2^T u2 = -u2^T K u2, Euler's theorem for
      // Psi4: c3 = u1^T K u3 = 2 u2^T K u2 - 4 Psi4(u1). g2 and Psi4(u1) from the even parts along
      // t u1 (the elastic supports' energy is quadratic: it is in the t^2 terms only).
      Timer      timer;
      const auto weights = even_series_weights();
      curve.estimate_third_order.c2 = curve.estimate_exact.c2;
      if (!samples.inside)
        {
          curve.estimate_third_order.c3 = std::numeric_limits<double>::quiet_NaN();
          curve.estimate_third_order.validity_force.fill(std::numeric_limits<double>::quiet_NaN());
          return false;
        }
      const double h = samples.h;
      const auto  &even_energy = samples.even_energy;
      const auto  &even_rhs    = samples.even_rhs;
      double quadratic = 0., psi4 = 0.;
      rhs              = 0.; // -g2
      for (unsigned int i = 0; i < 3; ++i)
        {
          quadratic += weights[0][i] * even_energy[i] / (h * h);
          psi4 += weights[1][i] * even_energy[i] / std::pow(h, 4);
          rhs.add(weights[0][i] / (h * h), even_rhs[i]);
        }
      curve.quadratic_term_check = std::abs(2. * quadratic - curve.linear_compliance) / curve.linear_compliance;

      const VectorType minus_g2(rhs);
      u2 = rhs;
      std::string failure;
      AssertThrow(solve_tangent(u2, failure), ExcMessage("The validity analysis' third-order term: " + failure));
      curve.estimate_third_order.c3 = 2. * (u2 * minus_g2) - 4. * psi4;
      curve.estimate_third_order.validity_force =
        series_validity_forces(curve.linear_compliance, curve.estimate_third_order.c2, curve.estimate_third_order.c3);
      curve.estimate_seconds += timer.wall_time();
      return true;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::estimate_at_rest(const VectorType &load, VectorType &u1, VectorType &u2,
                                                          ValidityCurve &curve)
    {
      // The exact second-order estimate from the linear response: its cost is this solve's and Psi3's integral (K's factorization would give u1 as well).
      std::string failure;
      tangent_at_rest(load);
      Timer solve_timer;
      AssertThrow(solve_tangent(u1, failure), ExcMessage("The validity analysis: " + failure + " at zero load."));
      curve.estimate_seconds  = solve_timer.wall_time();
      curve.linear_compliance = load * u1;
      const double step = estimate_second_order(u1, curve);
      Timer        sample_timer;
      const auto   samples = sample_along_response(u1, step);
      curve.estimate_seconds += sample_timer.wall_time();
      check_cubic_term(samples, curve);
      return estimate_third_order(samples, curve, u2);
    }

    template bool LargeDeformationSolve<SerialAlgebra>::estimate_at_rest(const Vector<double> &, Vector<double> &,
                                                                         Vector<double> &, ValidityCurve &);
    template bool LargeDeformationSolve<DistributedAlgebra>::estimate_at_rest(const TrilinosWrappers::MPI::Vector &,
                                                                              TrilinosWrappers::MPI::Vector &,
                                                                              TrilinosWrappers::MPI::Vector &,
                                                                              ValidityCurve &);
  } // namespace nonlinear
} // namespace modal_haptics
