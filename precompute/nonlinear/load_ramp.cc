// LargeDeformationSolve's load ramp: the levels from zero to the force limit, each level's Newton
// iterations from a predictor, with a line search, and the increment cut where a level fails.
#include "nonlinear/large_deformation_solve.h"

#include <deal.II/base/timer.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    namespace
    {
      // The converged states of a load ramp (the last three, the unloaded one while fewer levels are
      // known) and the predictors they give for the next level: the secant (the last two states
      // extrapolated; F u1 at the first level) and a quadratic (F u1 + F^2 u2 at the first level, u2
      // the second-order response; F u1 + F^2 c through the first level at the second; then through
      // the last three states).
      template <typename VectorType>
      class LoadPath
      {
      public:
        LoadPath(const VectorType &u1, const VectorType *u2)
          : u1(u1)
          , u2(u2)
          , states(3, u1)
        {
          for (auto &state : states)
            state = 0.;
        }
        void add(const double force, const VectorType &u)
        {
          forces    = {{force, forces[0], forces[1]}};
          states[2] = states[1];
          states[1] = states[0];
          states[0] = u;
          ++levels_known;
        }
        // False at the first level without u2.
        bool has_quadratic() const { return levels_known > 0 || u2 != nullptr; }
        void predict(const double x, VectorType &secant, VectorType &quadratic) const
        {
          const double c = forces[0], b = forces[1], a = forces[2];
          if (levels_known == 0)
            {
              secant = 0.;
              secant.add(x, u1);
              quadratic = secant;
              if (u2 != nullptr)
                quadratic.add(x * x, *u2);
              return;
            }
          secant = quadratic = states[0];
          secant.sadd(1. + (x - c) / (c - b), -(x - c) / (c - b), states[1]);
          if (levels_known == 1)
            {
              const double s = x / c;
              quadratic.sadd(s * s, x * (1. - s), u1);
              return;
            }
          quadratic *= (x - a) * (x - b) / ((c - a) * (c - b));
          quadratic.add((x - a) * (x - c) / ((b - a) * (b - c)), states[1], (x - b) * (x - c) / ((a - b) * (a - c)),
                        states[2]);
        }

      private:
        const VectorType       &u1;
        const VectorType       *u2;
        std::vector<VectorType> states;           // newest first
        std::array<double, 3>   forces{};         // [N], theirs
        unsigned int            levels_known = 0; // converged levels so far
      };

      // |x - y| (l2).
      template <typename VectorType>
      double l2_distance(const VectorType &x, const VectorType &y)
      {
        VectorType difference(x);
        difference -= y;
        return difference.l2_norm();
      }

      // A converged level on the curve: its force [N], felt displacement [m] and Newton's residuals.
      void add_level(ValidityCurve &curve, const double force, const double displacement,
                     const std::vector<double> &residuals, const double felt_error)
      {
        curve.forces.push_back(force);
        curve.displacements.push_back(displacement);
        curve.newton_iterations.push_back(residuals.size() - 1);
        curve.newton_residuals.push_back(residuals);
        curve.newton_felt_errors.push_back(felt_error);
      }
    } // namespace

    template <typename Algebra>
    typename LargeDeformationSolve<Algebra>::LevelOutcome LargeDeformationSolve<Algebra>::solve_level(VectorType &u, const double force,
                                                                           const VectorType &load,
                                                                           const VectorType &linear_response,
                                                                           const VectorType &predictor,
                                                                           const LoadRamp &ramp,
                                                                           const std::function<void(std::string)> &log)
    {
      LevelOutcome   outcome;
      const double   load_norm = force * load.l2_norm();
      VectorType trial(predictor), du(u);
      ++counts.tangent_assemblies;
      if (!assemble(trial, force, load, true)) // the predictor inverts an element: from the last level
        {
          trial = u;
          ++counts.tangent_assemblies;
          AssertThrow(assemble(trial, force, load, true), ExcInternalError()); // a converged state is valid
        }
      double residual = rhs.l2_norm() / load_norm;
      // The residual over the load; or the felt displacement's error (where the residual's norm is
      // held up by stiff components that barely move the point pressed: one Newton iteration from
      // the quadratic predictor leaves 1e-7 to 7e-6 of the load on the default scene's ribs, and
      // 3e-9 to 3e-8 of the felt displacement).
      // Once per iterate (two collective dot products under MPI).
      const auto converged = [&]() {
        outcome.felt_error = std::abs(linear_response * rhs) / std::abs(load * trial);
        return residual <= ramp.tolerance || outcome.felt_error <= ramp.felt_tolerance;
      };
      bool at_solution = converged();
      for (unsigned int iteration = 0;; ++iteration)
        {
          outcome.residuals.push_back(residual);
          if (at_solution)
            {
              u                 = trial;
              outcome.converged = true;
              return outcome;
            }
          if (iteration == ramp.max_iterations)
            {
              outcome.failure = "no convergence in " + std::to_string(ramp.max_iterations) + " Newton iterations";
              return outcome;
            }
          // An inexact Newton step, solved to a hundredth of the residual: the error it leaves is
          // smaller than the quadratic term's from r ~ 1e-2 down (and 1e-12 at most, the rounding
          // floor). Never tighter than needed to leave a hundredth of the level's tolerance: near
          // the solution the step's last CG iterations would only polish digits the next residual
          // does not show (that error, at most 1e-2 tolerance, stays below what the convergence
          // test and the quadratic rate r_k+1 / r_k^2 look at).
          const double forcing = std::max(std::clamp(1e-2 * residual, 1e-12, 1e-4), 1e-2 * ramp.tolerance / residual);
          if (!solve_tangent(du, outcome.failure, forcing))
            return outcome;
          const auto search = line_search(trial, du, force, load, load_norm, residual);
          const bool accepted = search.accepted;
          // The tangent at the new iterate, unless it is the solution.
          if (accepted)
            at_solution = converged();
          if (accepted && !at_solution)
            {
              ++counts.tangent_assemblies;
              assemble(trial, force, load, true);
            }
          if (log)
            {
              std::ostringstream line;
              line << "validity:   F = " << std::setprecision(4) << force << " N, Newton iteration " << iteration + 1
                   << ": |R|/|f| = " << std::scientific << std::setprecision(2) << residual
                   << ", felt displacement to " << outcome.felt_error << (accepted ? "" : " (line search failed)");
              log(line.str());
            }
          if (!accepted)
            {
              outcome.failure = search.inverted ? "an element inverts (det F <= 0) at every step length of the line search" :
                                           "the line search found no step that lowers the residual";
              return outcome;
            }
        }
    }

    template <typename Algebra>
    typename LargeDeformationSolve<Algebra>::LineSearchOutcome
    LargeDeformationSolve<Algebra>::line_search(VectorType &trial, const VectorType &du, const double force,
                                                const VectorType &load, const double load_norm, double &residual)
    {
      LineSearchOutcome search;
      const VectorType  start(trial);
      const double      start_energy = energy, slope = -(rhs * du);
      for (double step = 1.; step >= 1. / 1024.; step /= 2.)
        {
          trial = start;
          trial.add(step, du);
          ++counts.residual_assemblies;
          if (!assemble(trial, force, load, false))
            {
              search.inverted = true;
              continue;
            }
          const double trial_residual = rhs.l2_norm() / load_norm;
          if (energy <= start_energy + 1e-4 * step * slope || trial_residual < (1. - 1e-4 * step) * residual)
            {
              residual = trial_residual;
              search.accepted = true;
              break;
            }
        }
      return search;
    }

    template <typename Algebra>
    ValidityCurve LargeDeformationSolve<Algebra>::ramp_load(const VectorType &load, const LoadRamp &ramp,
                                                   const std::function<void(std::string)> &log)
    {
      Timer          timer;
      ValidityCurve  curve;
      VectorType u(space.owned_layout), du(u);
      tangent_factor.reset(); // another contact's tangent: K's factorization preconditions better
      curve.material    = law_name(law);
      curve.force_limit = ramp.force_limit;

      // The linear felt compliance from the tangent at the reference state (linear elasticity), and
      // the series estimates from the same response.
      VectorType u2(u);
      const bool has_u2 = estimate_at_rest(load, du, u2, curve);

      const double first_increment = ramp.force_limit / ramp.load_steps;
      const double least_increment = first_increment / std::pow(2., ramp.max_halvings);
      double       force = 0., increment = first_increment;
      // Each level starts from the quadratic predictor where it stays within a tenth of the increment
      // of the secant one, else from the secant (LoadPath). On a smooth curve (the default scene's
      // ribs) one Newton iteration from the quadratic meets the tolerance, where the secant needs
      // two. Where a level fails from the quadratic (on the elastica it overshoots into a state
      // whose tangent is indefinite), that level and the rest start from the secant.
      LoadPath<VectorType> path(du, has_u2 ? &u2 : nullptr);
      bool                 quadratic_usable = true;
      VectorType           secant(u), quadratic(u);
      while (force < ramp.force_limit)
        {
          const double target = std::min(force + increment, ramp.force_limit);
          path.predict(target, secant, quadratic);
          const bool use_quadratic = quadratic_usable && path.has_quadratic() &&
                                     l2_distance(quadratic, secant) <= 0.1 * l2_distance(secant, u);
          const VectorType &predictor = use_quadratic ? quadratic : secant;
          const auto outcome = solve_level(u, target, load, du, predictor, ramp, log);
          std::ostringstream line;
          line << "validity: F = " << std::setprecision(4) << target << " N, Newton |R|/|f|:" << std::scientific
               << std::setprecision(2);
          for (const double r : outcome.residuals)
            line << ' ' << r;
          if (outcome.converged)
            {
              force = target;
              path.add(force, u);
              add_level(curve, force, load * u, outcome.residuals, outcome.felt_error);
              line << " (" << outcome.residuals.size() - 1 << (outcome.residuals.size() == 2 ? " iteration" : " iterations")
                   << " from the " << (use_quadratic ? "quadratic" : "secant") << " predictor, felt displacement to "
                   << outcome.felt_error << ")";
              log(line.str());
              // Back up to the first increment once Newton converges fast again after a cut.
              if (outcome.residuals.size() <= 5)
                increment = std::min(2. * increment, first_increment);
              continue;
            }
          line << ": " << outcome.failure;
          if (use_quadratic) // the level again from the secant, the increment as it was
            {
              line << " (from the quadratic predictor: again from the secant)";
              log(line.str());
              quadratic_usable = false;
              continue;
            }
          log(line.str());
          increment /= 2.;
          if (increment < least_increment)
            {
              std::ostringstream reason;
              reason << outcome.failure << ", with the load increment cut to " << std::setprecision(3)
                     << 2. * increment << " N beyond " << force << " N";
              curve.stop_reason = reason.str();
              break;
            }
        }
      curve.force_reached = force;
      curve.seconds       = timer.wall_time();
      set_validity_forces(curve);
      return curve;
    }

    template ValidityCurve LargeDeformationSolve<SerialAlgebra>::ramp_load(const Vector<double> &, const LoadRamp &,
                                                                           const std::function<void(std::string)> &);
    template ValidityCurve
    LargeDeformationSolve<DistributedAlgebra>::ramp_load(const TrilinosWrappers::MPI::Vector &, const LoadRamp &,
                                                         const std::function<void(std::string)> &);
  } // namespace nonlinear
} // namespace modal_haptics
