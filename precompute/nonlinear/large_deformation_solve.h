// What the files of nonlinear/ share (included by them only): the large-deformation solve of one
// contact's load ramp (LargeDeformationSolve, its members defined by topic in large_deformation_solve.cc,
// series_estimate.cc and load_ramp.cc, each instantiating them for SerialAlgebra and
// DistributedAlgebra), the reference cells it assembles on, and the cubic term on the mesh.
#pragma once

#include "nonlinear/large_deformation.h"

#include "solvers/factorization.h"
#include "solvers/mumps_inverse.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/tensor.h>
#include <deal.II/fe/fe.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    inline MPI_Comm communicator(const DoFHandler<3> &dof_handler)
    {
      return dof_handler.get_triangulation().get_communicator();
    }

    // This process's cells, in the DoF handler's order.
    inline std::vector<DoFHandler<3>::active_cell_iterator> locally_owned_cells(const DoFHandler<3> &dof_handler)
    {
      std::vector<DoFHandler<3>::active_cell_iterator> cells;
      for (const auto &cell : dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
          cells.push_back(cell);
      return cells;
    }

    // u readable at every DoF of this process's cells: a ghosted copy (serially a plain one).
    template <typename Algebra>
    typename Algebra::Vector readable(const SpaceView<Algebra> &space, const typename Algebra::Vector &u)
    {
      typename Algebra::Vector copy = space.ghosted_layout;
      copy                          = u;
      return copy;
    }

    // Psi3(u) [J], the cubic term of the stored energy's expansion in u about the reference state
    // (cubic_energy.cc), by the space's quadrature on every process's cells; with largest_gradient,
    // also the largest |grad u| (Frobenius) at a quadrature point.
    template <typename Algebra>
    double cubic_energy(const SpaceView<Algebra> &space, const MaterialParameters &material, HyperelasticLaw law,
                        const typename Algebra::Vector &u, double *largest_gradient = nullptr);

    // The element is three copies of a scalar one (the displacement's components): DoF i is
    // component component[i] of scalar shape function scalar[i], and dof[s][c] the other way.
    struct VectorElementDofs
    {
      explicit VectorElementDofs(const FiniteElement<3> &fe)
        : component(fe.n_dofs_per_cell())
        , scalar(fe.n_dofs_per_cell())
        , dof(fe.base_element(0).n_dofs_per_cell())
      {
        AssertThrow(fe.n_base_elements() == 1 && fe.element_multiplicity(0) == 3, ExcInternalError());
        for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
          {
            std::tie(component[i], scalar[i]) = fe.system_to_component_index(i);
            dof[scalar[i]][component[i]]      = i;
          }
      }
      std::vector<unsigned int>                component, scalar;
      std::vector<std::array<unsigned int, 3>> dof;
    };

    // What every assembly reads of a cell's reference configuration (total Lagrangian: it never
    // changes), computed once per space instead of by FEValues at each of a contact's 20-odd
    // assemblies: the scalar shape functions' gradients and JxW at each quadrature point, and the
    // cell's DoFs (a cell's part is built in their ascending order).
    class ReferenceCells
    {
    public:
      ReferenceCells(const std::vector<DoFHandler<3>::active_cell_iterator> &cells, const Mapping<3> &mapping,
                     const FiniteElement<3> &fe, const Quadrature<3> &quadrature,
                     const std::vector<std::array<unsigned int, 3>> &dof);

      const unsigned int n_q, n_scalar, dofs_per_cell;
      // The n_scalar gradients at quadrature point q of cell c.
      const Tensor<1, 3> *gradients_at(const std::size_t c, const unsigned int q) const
      {
        return &gradients[(c * n_q + q) * n_scalar];
      }
      double JxW(const std::size_t c, const unsigned int q) const { return JxW_values[c * n_q + q]; }
      // The cell's DoFs in ascending order (the order a sparse matrix row takes additions fastest),
      // and where each local DoF stands in it (local DoF i is sorted_dofs(c)[positions(c)[i]]).
      const types::global_dof_index *sorted_dofs(const std::size_t c) const
      {
        return &sorted_dof_indices[c * dofs_per_cell];
      }
      const unsigned short *positions(const std::size_t c) const { return &sorted_position[c * dofs_per_cell]; }

    private:
      std::vector<Tensor<1, 3>>            gradients;
      std::vector<double>                  JxW_values;
      std::vector<types::global_dof_index> sorted_dof_indices;
      std::vector<unsigned short>          sorted_position;
    };

    struct NonlinearCellPart; // a cell's part of an assembly (large_deformation_solve.cc)

    template <typename Algebra>
    class LargeDeformationSolve
    {
    public:
      using VectorType = typename Algebra::Vector;

      LargeDeformationSolve(const SpaceView<Algebra> &space, const MaterialParameters &material,
                            const ModeParameters &modes, HyperelasticLaw law);

      // The dead load F * load ramped from 0 to ramp.force_limit: 'load' is a condensed unit patch
      // load W_v d (zero on constrained DoFs), which also reads the felt displacement d^T W_v^T u.
      // The curve's exact second-order estimate from the linear response u1 (curve.estimate_exact,
      // estimate_seconds) and Psi3's check against finite differences of the stored energy along
      // t u1 (curve.cubic_term_check).
      // Each level starts from the last converged one; a level Newton cannot reach (an inverted
      // element at every step length of the line search, a tangent that is not positive definite,
      // no convergence) is retried with half the increment, up to ramp.max_halvings; then the curve
      // stops with stop_reason and force_reached. Newton's relative residuals go to 'log', one line
      // per level.
      ValidityCurve ramp_load(const VectorType &load, const LoadRamp &ramp, const std::function<void(std::string)> &log);

      // What the solves cost: factorizations, CG iterations, assemblies (with the tangent and without).
      struct Counts
      {
        unsigned int factorizations = 0, cg_solves = 0, cg_iterations = 0, tangent_assemblies = 0,
                     residual_assemblies = 0;
        double assembly_seconds = 0., solve_seconds = 0.; // [s] assemblies; factorizations and CG
      } counts;

    private:
      // rhs = force * load - f_int(u) on the free DoFs, the potential energy (stored minus the load's
      // work); the tangent too when with_tangent. False when some quadrature point has det F <= 0
      // on any process (then rhs, energy and the tangent are not to be used).
      bool assemble(const VectorType &u, double force, const VectorType &load, bool with_tangent);
      bool assemble_at(const VectorType &u, double force, const VectorType &load,
                       bool with_tangent); // assemble without its timer
      // The tangent at u = 0 (K: the space's own where it has one, else assembled) and rhs = load.
      void tangent_at_rest(const VectorType &load);
      // This process's cells' share of assemble_at (before the exchange); false at det F <= 0.
      bool assemble_cells(const VectorType &u_read, bool with_tangent, double &local_energy);
      // One cell's part into rhs (and the tangent): through the constraints where the cell needs them.
      void add_cell_part(const NonlinearCellPart &part, bool with_tangent);
      // The elastic supports' share: linear springs on the reference faces (force k u, stiffness k).
      void add_elastic_faces(const VectorType &u_read, bool with_tangent, double &local_energy);
      struct LevelOutcome
      {
        bool                converged = false;
        std::vector<double> residuals; // |R| / |f| per iteration
        double              felt_error = 0.; // at the last iterate: |u1^T R| / |d| (LoadRamp::felt_tolerance)
        std::string         failure;
      };
      // Newton from the predictor (from u, the last converged state, where it inverts an element) to
      // the level 'force'; u is updated only when converged. linear_response: u1 = K^-1 load, the
      // felt displacement's adjoint for the convergence test.
      LevelOutcome solve_level(VectorType &u, double force, const VectorType &load, const VectorType &linear_response,
                               const VectorType &predictor, const LoadRamp &ramp,
                               const std::function<void(std::string)> &log);
      // The step along du from trial (where rhs and energy were assembled, at 'residual'), by
      // backtracking: halve it until every element keeps det F > 0 and the potential energy
      // has decreased enough along Newton's direction (Armijo, c = 1e-4; the direction descends
      // it while the tangent is positive definite), or the residual has (near the solution, where
      // the energy's change drowns in rounding). The residual alone is a poor guide far from the
      // solution: a slender part's linear predictor stretches it, and the axial force that
      // follows dwarfs the load, though the energy has gone down.
      // Leaves trial at the accepted point (rhs and energy assembled there, residual its own) or at
      // the last step tried.
      struct LineSearchOutcome
      {
        bool accepted = false;
        bool inverted = false; // some step inverted an element
      };
      LineSearchOutcome line_search(VectorType &trial, const VectorType &du, double force, const VectorType &load,
                                    double load_norm, double &residual);
      // The tangent at rest, u1 = K^-1 load into u1 (curve.linear_compliance), and the series
      // estimates from it (estimate_second_order, the samples, estimate_third_order: u2 into u2,
      // false where there is none).
      bool estimate_at_rest(const VectorType &load, VectorType &u1, VectorType &u2, ValidityCurve &curve);
      // tangent^-1 rhs into du; false (and 'failure') when the tangent is not positive definite.
      // With space.use_cg, CG preconditioned by the last factorization (K's, the space's, until a
      // tangent is factorized) to |rhs - tangent du| <= tolerance |rhs|; the tangent is factorized
      // (and preconditions from then on) only where CG stalls or meets negative curvature.
      bool solve_tangent(VectorType &du, std::string &failure, double tolerance = 1e-12);
      bool solve_tangent_system(VectorType &du, std::string &failure, double tolerance); // untimed
      bool preconditioned_cg(VectorType &du, double tolerance);
      // curve.estimate_exact, from u1 = K^-1 load (c2 = -3 Psi3(u1)). Returns the step h [N] of the
      // finite differences along t u1: the largest displacement gradient of h u1 is 1e-3, where the
      // expansion's cubic and quartic terms stand well above the rounding of the energy's quadratic
      // one (1e-3 and 1e-6 of it) and the orders left out are negligible; whatever the force limit (a
      // step from it, tried first, met only rounding at a limit of 1e-3 N).
      double estimate_second_order(const VectorType &u1, ValidityCurve &curve);
      // The stored energy and rhs = -f_int along +-t u1 at t = h, 2 h, 3 h, assembled once for both
      // uses: the odd parts of the energy check Psi3, the even parts give grad Psi3 and Psi4.
      struct ResponseSamples
      {
        bool                    inside = false; // no element inverted at any sample
        double                  h      = 0.;    // [N], quartered from the step asked for where one did
        std::array<double, 3>   odd_energy{}, even_energy{}; // (g(t u1) -+ g(-t u1)) / 2 at t = h, 2 h, 3 h
        std::vector<VectorType> even_rhs;
      };
      // The samples at the step h, quartered until no element inverts (at most 7 times).
      ResponseSamples sample_along_response(const VectorType &u1, double h);
      // The samples at t = h, 2 h, 3 h into 'samples'; false where an element inverts.
      bool sample_at_steps(const VectorType &u1, double h, ResponseSamples &samples);
      // curve.cubic_term_check: Psi3 (from curve.estimate_exact) against the odd part's Richardson
      // extrapolation.
      static void check_cubic_term(const ResponseSamples &samples, ValidityCurve &curve);
      // curve.estimate_third_order and its check from the samples; 'tangent' must still be K (at u = 0).
      // Also the second-order response u2 (u(F) = F u1 + F^2 u2 + O(F^3)) into 'u2'; false where the
      // samples could not give it.
      bool estimate_third_order(const ResponseSamples &samples, ValidityCurve &curve, VectorType &u2);

      const SpaceView<Algebra>                   space;
      const MaterialParameters                   material;
      const ModeParameters                       modes;
      const double                               mu, lambda;
      const HyperelasticLaw                      law;
      // Built once: every residual and tangent assembly walks the same cells and element.
      const std::vector<DoFHandler<3>::active_cell_iterator> owned_cells;
      const VectorElementDofs                                element_dofs;
      const ReferenceCells                                   reference;
      using CellIterator = typename std::vector<DoFHandler<3>::active_cell_iterator>::const_iterator;
      std::vector<double>                                    cell_energy;   // per owned cell, at the last assembly
      const std::vector<char>                                through_constraints; // per owned cell
      typename Algebra::Matrix                   tangent;
      VectorType                                 rhs;
      double                                     energy = 0.; // [J]
      std::unique_ptr<typename Algebra::Inverse> tangent_factor; // the last factorized tangent
    };
  } // namespace nonlinear
} // namespace modal_haptics
