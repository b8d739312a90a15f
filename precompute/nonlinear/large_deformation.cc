// The geometrically nonlinear static solve and the validity analysis (large_deformation.h).
// Total Lagrangian: the unknown is the displacement u on the reference mesh, F = I + grad u, and
// the internal force is the integral of the first Piola-Kirchhoff stress P(F) against the shape
// functions' reference gradients; its derivative is the tangent, symmetric for a stored energy.
#include "nonlinear/large_deformation.h"

#include "solvers/factorization.h"
#include "space/modal_space.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/point.h>
#include <deal.II/base/symmetric_tensor.h>
#include <deal.II/base/tensor.h>
#include <deal.II/base/timer.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/fe_values_extractors.h>
#include <deal.II/lac/full_matrix.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    std::string law_name(const HyperelasticLaw law)
    {
      return law == HyperelasticLaw::neo_hookean ? "neo-Hookean" : "St. Venant-Kirchhoff";
    }

    namespace
    {
      const Tensor<2, 3> identity(unit_symmetric_tensor<3>());

      // P(F) and its directional derivative dP = A : G for the gradients G = e_c (x) g of the shape
      // functions (one nonzero row each) at one quadrature point. Strain, ln J and the stress are
      // computed from H = grad u, not from F = I + H, so that they keep their relative accuracy at
      // small strain (F^T F - I loses it to rounding: a 1e-3 N load on a steel beam, strains of
      // 1e-8, would leave Newton's residual above its tolerance).
      class StressAtPoint
      {
      public:
        StressAtPoint(const HyperelasticLaw law, const double mu, const double lambda, const Tensor<2, 3> &H)
          : law(law), mu(mu), lambda(lambda), F(identity + H)
        {
          const Tensor<2, 3> E = 0.5 * (H + transpose(H) + transpose(H) * H); // Green-Lagrange strain
          if (law == HyperelasticLaw::saint_venant_kirchhoff)
            {
              S = lambda * trace(E) * identity + 2. * mu * E;
              P = F * S;
              W = 0.5 * lambda * trace(E) * trace(E) + mu * scalar_product(E, E);
            }
          else
            {
              // J - 1 = tr H + (tr^2 H - tr H^2) / 2 + det H, and F - F^-T = F^-T (F^T F - I) = 2 F^-T E.
              const double J_minus_1 = trace(H) + 0.5 * (trace(H) * trace(H) - trace(H * H)) + determinant(H);
              F_inverse_T            = transpose(invert(F));
              log_J                  = std::log1p(J_minus_1);
              P                      = 2. * mu * F_inverse_T * E + lambda * log_J * F_inverse_T;
              W                      = mu * trace(E) - mu * log_J + 0.5 * lambda * log_J * log_J;
            }
        }

        const Tensor<2, 3> &stress() const { return P; }
        double              energy() const { return W; } // stored energy per reference volume

        Tensor<2, 3> derivative(const Tensor<2, 3> &G) const
        {
          if (law == HyperelasticLaw::saint_venant_kirchhoff)
            {
              const Tensor<2, 3> FtG = transpose(F) * G;
              const Tensor<2, 3> dE  = 0.5 * (FtG + transpose(FtG));
              return G * S + F * (lambda * trace(dE) * identity + 2. * mu * dE);
            }
          // d(F^-T) = -F^-T dF^T F^-T, d ln J = tr(F^-1 dF) = F^-T : dF.
          return mu * G + (mu - lambda * log_J) * (F_inverse_T * transpose(G) * F_inverse_T) +
                 lambda * scalar_product(F_inverse_T, G) * F_inverse_T;
        }

      private:
        const HyperelasticLaw law;
        const double          mu, lambda;
        const Tensor<2, 3>    F;
        Tensor<2, 3>          S, P, F_inverse_T;
        double                log_J = 0., W = 0.;
      };
    } // namespace

    LargeDeformationSolve::LargeDeformationSolve(const SpaceView &space, const MaterialParameters &material,
                                                 const HyperelasticLaw law)
      : space(space)
      , mu(material.youngs_modulus / (2. * (1. + material.poissons_ratio)))
      , lambda(material.youngs_modulus * material.poissons_ratio /
               ((1. + material.poissons_ratio) * (1. - 2. * material.poissons_ratio)))
      , law(law)
    {
      tangent.reinit(space.sparsity);
      rhs.reinit(space.dof_handler.n_dofs());
    }

    bool LargeDeformationSolve::assemble(const Vector<double> &u, const double force, const Vector<double> &load,
                                         const bool with_tangent)
    {
      const auto        &fe            = space.dof_handler.get_fe();
      const unsigned int dofs_per_cell = fe.n_dofs_per_cell();
      FEValues<3>        fe_values(space.mapping, fe, space.quadrature, update_gradients | update_JxW_values);
      const FEValuesExtractors::Vector displacement(0);
      std::vector<Tensor<2, 3>>        grad_u(space.quadrature.size());
      std::vector<Tensor<2, 3>>        shape_gradient(dofs_per_cell), shape_dP(dofs_per_cell);
      FullMatrix<double>               cell_K(dofs_per_cell, dofs_per_cell);
      Vector<double>                   cell_rhs(dofs_per_cell), cell_u(dofs_per_cell);
      std::vector<types::global_dof_index> dof_indices(dofs_per_cell);
      std::vector<unsigned int>            component(dofs_per_cell);
      for (unsigned int i = 0; i < dofs_per_cell; ++i)
        component[i] = fe.system_to_component_index(i).first;

      rhs    = 0.;
      energy = 0.;
      if (with_tangent)
        tangent = 0.;
      for (const auto &cell : space.dof_handler.active_cell_iterators())
        {
          fe_values.reinit(cell);
          fe_values[displacement].get_function_gradients(u, grad_u);
          cell_K   = 0.;
          cell_rhs = 0.;
          for (unsigned int q = 0; q < space.quadrature.size(); ++q)
            {
              if (!(determinant(identity + grad_u[q]) > 0.))
                return false; // an inverted (or degenerate) element: no stress is defined
              const StressAtPoint stress(law, mu, lambda, grad_u[q]);
              const double        JxW = fe_values.JxW(q);
              energy += stress.energy() * JxW;
              for (unsigned int i = 0; i < dofs_per_cell; ++i)
                {
                  shape_gradient[i]               = Tensor<2, 3>();
                  shape_gradient[i][component[i]] = fe_values.shape_grad(i, q);
                  cell_rhs(i) -= stress.stress()[component[i]] * shape_gradient[i][component[i]] * JxW;
                }
              if (with_tangent)
                {
                  for (unsigned int j = 0; j < dofs_per_cell; ++j)
                    shape_dP[j] = stress.derivative(shape_gradient[j]);
                  for (unsigned int i = 0; i < dofs_per_cell; ++i)
                    for (unsigned int j = 0; j < dofs_per_cell; ++j)
                      cell_K(i, j) += shape_dP[j][component[i]] * shape_gradient[i][component[i]] * JxW;
                }
            }
          cell->get_dof_indices(dof_indices);
          if (with_tangent)
            space.constraints.distribute_local_to_global(cell_K, cell_rhs, dof_indices, tangent, rhs);
          else
            space.constraints.distribute_local_to_global(cell_rhs, dof_indices, rhs);
        }
      // Elastic supports are linear springs on the reference faces: force k u, stiffness k.
      for (const auto &face : space.elastic_faces)
        {
          space_parts::elastic_face_matrix(space.mapping, fe, face, cell_K);
          face.cell->get_dof_indices(dof_indices);
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            cell_u(i) = u(dof_indices[i]);
          cell_K.vmult(cell_rhs, cell_u);
          energy += 0.5 * (cell_u * cell_rhs);
          cell_rhs *= -1.;
          if (with_tangent)
            space.constraints.distribute_local_to_global(cell_K, cell_rhs, dof_indices, tangent, rhs);
          else
            space.constraints.distribute_local_to_global(cell_rhs, dof_indices, rhs);
        }
      rhs.add(force, load);
      energy -= force * (load * u);
      return true;
    }

    bool LargeDeformationSolve::solve_tangent(Vector<double> &du, std::string &failure)
    {
      std::unique_ptr<Factorization> factor;
      try
        {
          factor = space.factorization == FactorizationKind::umfpack ?
                     make_umfpack_factorization(tangent, nullptr, 0.) :
                     make_cholmod_factorization(tangent, nullptr, 0.);
        }
      catch (const ExceptionBase &e)
        {
          if (std::string(e.what()).find("not positive definite") == std::string::npos)
            throw;
          failure = "the tangent stiffness is not positive definite (a limit point: buckling, snap-through "
                    "or a material instability)";
          return false;
        }
      du = rhs;
      factor->solve_block(du.data(), 1);
      space.constraints.distribute(du);
      return true;
    }

    LargeDeformationSolve::LevelOutcome LargeDeformationSolve::solve_level(Vector<double> &u, const double force,
                                                                           const Vector<double> &load,
                                                                           const Vector<double> &predictor,
                                                                           const LoadRamp &ramp,
                                                                           const std::function<void(std::string)> &log)
    {
      LevelOutcome   outcome;
      const double   load_norm = force * load.l2_norm();
      Vector<double> trial(predictor), du(u.size());
      if (!assemble(trial, force, load, true)) // the predictor inverts an element: from the last level
        {
          trial = u;
          AssertThrow(assemble(trial, force, load, true), ExcInternalError()); // a converged state is valid
        }
      double residual = rhs.l2_norm() / load_norm;
      for (unsigned int iteration = 0;; ++iteration)
        {
          outcome.residuals.push_back(residual);
          if (residual <= ramp.tolerance)
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
          if (!solve_tangent(du, outcome.failure))
            return outcome;
          // Backtracking: halve the step until every element keeps det F > 0 and the potential energy
          // has decreased enough along Newton's direction (Armijo, c = 1e-4; the direction descends
          // it while the tangent is positive definite), or the residual has (near the solution, where
          // the energy's change drowns in rounding). The residual alone is a poor guide far from the
          // solution: a slender part's linear predictor stretches it, and the axial force that
          // follows dwarfs the load, though the energy has gone down.
          const Vector<double> start(trial);
          const double         start_energy = energy, slope = -(rhs * du);
          bool                 accepted = false, inverted = false;
          double               step_taken = 0.;
          for (double step = 1.; step >= 1. / 1024.; step /= 2.)
            {
              trial = start;
              trial.add(step, du);
              if (!assemble(trial, force, load, step == 1.)) // the full step is the one usually taken
                {
                  inverted = true;
                  continue;
                }
              const double trial_residual = rhs.l2_norm() / load_norm;
              if (energy <= start_energy + 1e-4 * step * slope || trial_residual < (1. - 1e-4 * step) * residual)
                {
                  residual   = trial_residual;
                  accepted   = true;
                  step_taken = step;
                  break;
                }
            }
          if (accepted && step_taken < 1.)
            assemble(trial, force, load, true); // the tangent at the new iterate
          if (log)
            {
              std::ostringstream line;
              line << "validity:   F = " << std::setprecision(4) << force << " N, Newton iteration " << iteration + 1
                   << ": |R|/|f| = " << std::scientific << std::setprecision(2) << residual
                   << (accepted ? "" : " (line search failed)");
              log(line.str());
            }
          if (!accepted)
            {
              outcome.failure = inverted ? "an element inverts (det F <= 0) at every step length of the line search" :
                                           "the line search found no step that lowers the residual";
              return outcome;
            }
        }
    }

    ValidityCurve LargeDeformationSolve::ramp_load(const Vector<double> &load, const LoadRamp &ramp,
                                                   const std::function<void(std::string)> &log)
    {
      Timer          timer;
      ValidityCurve  curve;
      Vector<double> u(space.dof_handler.n_dofs()), du(u.size());
      curve.material    = law_name(law);
      curve.force_limit = ramp.force_limit;

      // The linear felt compliance from the tangent at the reference state (linear elasticity).
      std::string failure;
      assemble(u, 1., load, true);
      AssertThrow(solve_tangent(du, failure), ExcMessage("The validity analysis: " + failure + " at zero load."));
      curve.linear_compliance = load * du;

      const double first_increment = ramp.force_limit / ramp.load_steps;
      const double least_increment = first_increment / std::pow(2., ramp.max_halvings);
      double       force = 0., increment = first_increment;
      // The secant predictor: the last two converged states extrapolated to the new level (the
      // linear response at the first level).
      Vector<double> u_before(u.size()), predictor(u.size());
      double         force_before = 0.;
      while (force < ramp.force_limit)
        {
          const double target = std::min(force + increment, ramp.force_limit);
          predictor           = u;
          if (force == 0.)
            predictor.add(target, du);
          else
            predictor.sadd(1. + (target - force) / (force - force_before), -(target - force) / (force - force_before),
                           u_before);
          const Vector<double> u_last(u);
          const auto           outcome = solve_level(u, target, load, predictor, ramp, log);
          std::ostringstream line;
          line << "validity: F = " << std::setprecision(4) << target << " N, Newton |R|/|f|:" << std::scientific
               << std::setprecision(2);
          for (const double r : outcome.residuals)
            line << ' ' << r;
          if (outcome.converged)
            {
              u_before     = u_last;
              force_before = force;
              force        = target;
              curve.forces.push_back(force);
              curve.displacements.push_back(load * u);
              curve.newton_iterations.push_back(outcome.residuals.size() - 1);
              curve.newton_residuals.push_back(outcome.residuals);
              line << " (" << outcome.residuals.size() - 1 << " iterations)";
              log(line.str());
              // Back up to the first increment once Newton converges fast again after a cut.
              if (outcome.residuals.size() <= 5)
                increment = std::min(2. * increment, first_increment);
              continue;
            }
          line << ": " << outcome.failure;
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

    void set_validity_forces(ValidityCurve &curve)
    {
      const auto departure = [&](const std::size_t k) {
        const double compliance = curve.displacements[k] / curve.forces[k];
        return compliance > 0. ? std::abs(curve.linear_compliance / compliance - 1.) :
                                 std::numeric_limits<double>::infinity();
      };
      for (unsigned int level = 0; level < validity_departures.size(); ++level)
        {
          const double wanted = validity_departures[level];
          // Not reached on the curve: beyond the limit, or at most where the part stopped carrying.
          curve.validity_force[level] =
            curve.stop_reason.empty() ? std::numeric_limits<double>::infinity() : curve.force_reached;
          double previous_force = 0., previous_departure = 0.; // the curve starts linear at F = 0
          for (std::size_t k = 0; k < curve.forces.size(); ++k)
            {
              const double d = departure(k);
              if (d >= wanted)
                {
                  curve.validity_force[level] =
                    std::isfinite(d) ? previous_force + (curve.forces[k] - previous_force) * (wanted - previous_departure) /
                                                          (d - previous_departure) :
                                       previous_force;
                  break;
                }
              previous_force     = curve.forces[k];
              previous_departure = d;
            }
        }
    }

    std::array<double, 3> inward_normal(const ContactSurface &display, const unsigned int vertex,
                                        const std::function<double(const meshing::Point3 &)> &outside)
    {
      Tensor<1, 3> normal;
      const auto   point = [&](const unsigned int v) {
        return Point<3>(display.vertices[v][0], display.vertices[v][1], display.vertices[v][2]);
      };
      for (unsigned int k = display.vertex_triangle_offsets[vertex]; k < display.vertex_triangle_offsets[vertex + 1]; ++k)
        {
          const auto &t = display.triangles[display.vertex_triangles[k]];
          normal += cross_product_3d(point(t[1]) - point(t[0]), point(t[2]) - point(t[0])); // twice the area
        }
      AssertThrow(normal.norm() > 0., ExcMessage("Display vertex " + std::to_string(vertex) + " has no triangle."));
      normal /= normal.norm();
      // A tenth of the local triangle size away on either side: the side inside the part is the one
      // less far outside the mesh.
      const double step  = 0.1 * std::sqrt(3. * display.vertex_area[vertex]);
      const auto   moved = [&](const double sign) {
        const Point<3> x = point(vertex) + sign * step * normal;
        return outside({{x[0], x[1], x[2]}});
      };
      const double sign = moved(-1.) <= moved(1.) ? -1. : 1.;
      return {{sign * normal[0], sign * normal[1], sign * normal[2]}};
    }

    void analyse_validity(const SpaceView &space, const SceneParameters &scene, const SpaceTask &task,
                          const ContactSurface &display,
                          const std::function<Vector<double>(unsigned int, const std::array<double, 3> &)> &patch_load,
                          const std::function<double(const meshing::Point3 &)> &outside, ModalSpaceResult &result,
                          const std::function<void(std::string)> &log,
                          const std::function<void(std::string)> &summarize)
    {
      if (result.n_rigid_body_modes > 0)
        {
          summarize("validity analysis left out: the supports leave rigid motions free (" + result.free_motions +
              "), which a dead load would accelerate without bound");
          return;
        }
      const auto &contact = scene.contact;
      LoadRamp    ramp;
      ramp.force_limit = contact.force_limit;
      ramp.load_steps  = contact.validity_load_steps;
      const auto law = contact.validity_neo_hookean ? HyperelasticLaw::neo_hookean : HyperelasticLaw::saint_venant_kirchhoff;
      LargeDeformationSolve solve(space, scene.material, law);
      for (const unsigned int vertex : task.validity_vertices)
        {
          const auto direction =
            contact.validity_direction ? *contact.validity_direction : inward_normal(display, vertex, outside);
          std::ostringstream heading;
          heading << "validity: display vertex " << vertex << ", pressed along (" << std::setprecision(3)
                  << direction[0] << ", " << direction[1] << ", " << direction[2] << ") up to " << ramp.force_limit
                  << " N ('Contact/Force limit'), " << law_name(law);
          log(heading.str());
          auto curve      = solve.ramp_load(patch_load(vertex, direction), ramp, log);
          curve.vertex    = vertex;
          curve.direction = direction;
          std::ostringstream summary;
          summary << "validity: display vertex " << vertex << ": " << curve.forces.size() << " load levels in "
                  << std::fixed << std::setprecision(1) << curve.seconds << " s; linear felt compliance holds to 1/5/10 % up to "
                  << std::setprecision(3) << std::defaultfloat << curve.validity_force[0] << " / "
                  << curve.validity_force[1] << " / " << curve.validity_force[2] << " N";
          if (!curve.stop_reason.empty())
            summary << "; the solve stopped at " << curve.force_reached << " N of " << ramp.force_limit
                    << " N: " << curve.stop_reason;
          summarize(summary.str());
          result.validity.push_back(std::move(curve));
        }
    }
  } // namespace nonlinear
} // namespace modal_haptics
