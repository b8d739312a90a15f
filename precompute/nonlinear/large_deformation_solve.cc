// LargeDeformationSolve's assembly of the residual and the tangent over the reference cells, and its
// tangent solves (CG preconditioned by the last factorization, or a new factorization).
// Total Lagrangian: the unknown is the displacement u on the reference mesh, F = I + grad u, and
// the internal force is the integral of the first Piola-Kirchhoff stress P(F) against the shape
// functions' reference gradients; its derivative is the tangent, symmetric for a stored energy.
// Each process integrates over its own cells, the matrices and vectors exchange what crosses the
// partition (compress), and energies are summed.
#include "nonlinear/large_deformation_solve.h"
#include "nonlinear/hyperelastic_stress.h"

#include "solvers/factorization.h"
#include "solvers/mumps_inverse.h"
#include "assembly/elasticity.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/timer.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <atomic>
#include <tuple>
#include <type_traits>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    namespace
    {
      // The factorization of a tangent by the space's own direct solver, or null where the tangent
      // is not positive definite: CHOLMOD's Cholesky refuses it, MUMPS's L D L^T (with pivoting, for
      // an indefinite tangent factorizes too) counts its negative eigenvalues (Sylvester's inertia).
      // UMFPACK's and Amesos' LU do not tell: Newton then meets the limit point as a failed line search.
      std::unique_ptr<Factorization> factorize_tangent(const SparseMatrix<double> &tangent, const ModeParameters &modes)
      {
        try
          {
            return modes.factorization_kind == FactorizationKind::umfpack ? make_umfpack_factorization(tangent, nullptr, 0.) :
                                                                             make_cholmod_factorization(tangent, nullptr, 0.);
          }
        catch (const ExceptionBase &e)
          {
            if (std::string(e.what()).find("not positive definite") == std::string::npos)
              throw;
            return nullptr;
          }
      }

      std::unique_ptr<DistributedInverse> factorize_tangent(const TrilinosWrappers::SparseMatrix &tangent,
                                                            const ModeParameters                 &modes)
      {
        FactorizationStatistics statistics;
        auto inverse = make_mumps_inverse(tangent, modes.distributed_factorization, /*positive_definite*/ false,
                                          modes.factor_directory, statistics,
                                          [](const solver_choice::MumpsPrediction &) { return solver_choice::Placement::memory; });
        if (inverse->negative_eigenvalues() > 0)
          return nullptr;
        return inverse;
      }

      // The cell matrix from add_tangent's blocks (block (a, b), b <= a, and its transpose), local DoF
      // i at row and column position[i].
      void scatter_tangent_blocks(const std::vector<double> &blocks, const std::vector<std::array<unsigned int, 3>> &dof,
                                  const unsigned short *position, FullMatrix<double> &K)
      {
        const unsigned int n = dof.size();
        for (unsigned int a = 0; a < n; ++a)
          for (unsigned int b = 0; b <= a; ++b)
            {
              const double *block = &blocks[9 * (a * n + b)];
              for (unsigned int ci = 0; ci < 3; ++ci)
                for (unsigned int cj = 0; cj < 3; ++cj)
                  {
                    const unsigned int i = position[dof[a][ci]], j = position[dof[b][cj]];
                    K(i, j) = K(j, i) = block[3 * ci + cj];
                  }
            }
      }

      // Per cell: whether its part goes through the constraints (a constrained DoF; every cell of a
      // distributed tangent, whose rows may be another process's); the rest is added row by row.
      template <typename Algebra>
      std::vector<char> cells_through_constraints(const ReferenceCells &reference, const std::size_t n_cells,
                                                  const AffineConstraints<double> &constraints)
      {
        std::vector<char> through(n_cells, !std::is_same_v<Algebra, SerialAlgebra>);
        for (std::size_t c = 0; c < n_cells; ++c)
          for (unsigned int i = 0; i < reference.dofs_per_cell && !through[c]; ++i)
            through[c] = constraints.is_constrained(reference.sorted_dofs(c)[i]);
        return through;
      }
    } // namespace

    ReferenceCells::ReferenceCells(const std::vector<DoFHandler<3>::active_cell_iterator> &cells, const Mapping<3> &mapping,
                                   const FiniteElement<3> &fe, const Quadrature<3> &quadrature,
                                   const std::vector<std::array<unsigned int, 3>> &dof)
      : n_q(quadrature.size())
      , n_scalar(dof.size())
      , dofs_per_cell(fe.n_dofs_per_cell())
      , gradients(cells.size() * n_q * n_scalar)
      , JxW_values(cells.size() * n_q)
      , sorted_dof_indices(cells.size() * dofs_per_cell)
      , sorted_position(cells.size() * dofs_per_cell)
    {
      parallel::apply_to_subranges(
        std::size_t(0), cells.size(),
        [&](const std::size_t begin, const std::size_t end) {
          FEValues<3>                          fe_values(mapping, fe, quadrature, update_gradients | update_JxW_values);
          std::vector<types::global_dof_index> indices(dofs_per_cell);
          std::vector<unsigned int>            order(dofs_per_cell);
          for (std::size_t c = begin; c < end; ++c)
            {
              fe_values.reinit(cells[c]);
              for (unsigned int q = 0; q < n_q; ++q)
                {
                  JxW_values[c * n_q + q] = fe_values.JxW(q);
                  for (unsigned int a = 0; a < n_scalar; ++a)
                    gradients[(c * n_q + q) * n_scalar + a] = fe_values.shape_grad(dof[a][0], q);
                }
              cells[c]->get_dof_indices(indices);
              assembly::ascending_dof_order(indices, order);
              for (unsigned int k = 0; k < dofs_per_cell; ++k)
                {
                  sorted_dof_indices[c * dofs_per_cell + k]     = indices[order[k]];
                  sorted_position[c * dofs_per_cell + order[k]] = k;
                }
            }
        },
        64);
    }

    template <typename Algebra>
    LargeDeformationSolve<Algebra>::LargeDeformationSolve(const SpaceView<Algebra> &space, const MaterialParameters &material,
                                                          const ModeParameters &modes, const HyperelasticLaw law)
      : space(space)
      , material(material)
      , modes(modes)
      , mu(lame_constants(material)[0])
      , lambda(lame_constants(material)[1])
      , law(law)
      , owned_cells(locally_owned_cells(space.dof_handler))
      , element_dofs(space.dof_handler.get_fe())
      , reference(owned_cells, space.mapping, space.dof_handler.get_fe(), space.quadrature, element_dofs.dof)
      , cell_energy(owned_cells.size())
      , through_constraints(cells_through_constraints<Algebra>(reference, owned_cells.size(), space.constraints))
    {
      tangent.reinit(space.sparsity);
      rhs = space.owned_layout;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::assemble(const VectorType &u, const double force, const VectorType &load,
                                         const bool with_tangent)
    {
      Timer timer;
      const bool valid = assemble_at(u, force, load, with_tangent);
      counts.assembly_seconds += timer.wall_time();
      return valid;
    }

    template <typename Algebra>
    void LargeDeformationSolve<Algebra>::tangent_at_rest(const VectorType &load)
    {
      if (space.stiffness == nullptr)
        {
          ++counts.tangent_assemblies;
          assemble(space.owned_layout, 1., load, true);
          return;
        }
      tangent.copy_from(*space.stiffness);
      rhs    = load;
      energy = 0.;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::assemble_at(const VectorType &u, const double force, const VectorType &load,
                                                     const bool with_tangent)
    {
      rhs = 0.;
      if (with_tangent)
        tangent = 0.;
      double     local_energy = 0.;
      const bool valid        = assemble_cells(readable(space, u), with_tangent, local_energy);
      // Every process exchanges what it added to others' rows, valid or not: a collective step.
      if (with_tangent)
        tangent.compress(VectorOperation::add);
      rhs.compress(VectorOperation::add);
      const MPI_Comm comm = communicator(space.dof_handler);
      if (Utilities::MPI::min(int(valid), comm) == 0)
        return false;
      energy = Utilities::MPI::sum(local_energy, comm);
      rhs.add(force, load);
      energy -= force * (load * u);
      return true;
    }

    // What a thread needs to assemble a cell of the residual and the tangent (WorkStream's scratch:
    // copied once per thread).
    struct NonlinearScratch
    {
      explicit NonlinearScratch(const unsigned int n_scalar, const unsigned int dofs_per_cell)
        : u(dofs_per_cell)
        , work(n_scalar)
        , blocks(9 * n_scalar * n_scalar)
      {}
      std::vector<double>       u;      // the cell's DoF values
      std::vector<Tensor<1, 3>> work;   // per scalar shape function
      std::vector<double>       blocks; // add_tangent's 3 x 3 blocks
    };

    // A cell's part: its rows and columns in the order of its DoFs' global indices. Added by one
    // thread at a time in the cells' order, so each entry gets its sums in an order fixed by the
    // mesh, not by which thread ends first. (Colours of cells sharing no row, each colour added on
    // every thread at once, were slower, docs/performance.md: a colour's cells are spread over the
    // whole matrix, while consecutive cells in their order share rows in cache.)
    struct NonlinearCellPart
    {
      explicit NonlinearCellPart(const unsigned int dofs_per_cell)
        : K(dofs_per_cell, dofs_per_cell)
        , rhs(dofs_per_cell)
        , dof_indices(dofs_per_cell)
      {}
      FullMatrix<double>                   K;
      Vector<double>                       rhs;
      std::vector<types::global_dof_index> dof_indices;
      std::size_t                          cell   = 0; // in owned_cells
      double                               energy = 0.;
      bool                                 valid  = false; // false: an inverted element, or skipped after one
    };

    // The cells on deal.II's threads (WorkStream), as the linear assembly: the tangent assemblies
    // are most of a validity contact's time (docs/performance.md).
    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::assemble_cells(const VectorType &u_read, const bool with_tangent,
                                                        double &local_energy)
    {
      const auto        &fe            = space.dof_handler.get_fe();
      const unsigned int dofs_per_cell = fe.n_dofs_per_cell();
      const auto        &component     = element_dofs.component;
      const auto        &scalar        = element_dofs.scalar;
      const auto        &dof           = element_dofs.dof;
      const unsigned int n_scalar      = dof.size();
      std::atomic<bool>  inverted{false};

      const auto worker = [&](const CellIterator &cell, NonlinearScratch &scratch, NonlinearCellPart &part) {
          part.valid = false;
          if (inverted.load(std::memory_order_relaxed))
            return; // the assembly has failed: the rest is not needed
          const std::size_t c = part.cell = cell - owned_cells.cbegin();
          const unsigned short *position = reference.positions(c);
          part.dof_indices.assign(reference.sorted_dofs(c), reference.sorted_dofs(c) + dofs_per_cell);
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            scratch.u[i] = u_read(part.dof_indices[position[i]]);
          part.rhs    = 0.;
          part.energy = 0.;
          if (with_tangent)
            std::fill(scratch.blocks.begin(), scratch.blocks.end(), 0.);
          for (unsigned int q = 0; q < reference.n_q; ++q)
            {
              const Tensor<1, 3> *g = reference.gradients_at(c, q);
              Tensor<2, 3>        grad_u; // grad_u[i][j] = d u_i / d X_j
              for (unsigned int a = 0; a < n_scalar; ++a)
                for (unsigned int comp = 0; comp < 3; ++comp)
                  grad_u[comp] += scratch.u[dof[a][comp]] * g[a];
              if (!(determinant(identity + grad_u) > 0.))
                {
                  inverted = true; // an inverted (or degenerate) element: no stress is defined
                  return;
                }
              const StressAtPoint stress(law, mu, lambda, grad_u);
              const double        JxW = reference.JxW(c, q);
              part.energy += stress.energy() * JxW;
              for (unsigned int i = 0; i < dofs_per_cell; ++i)
                part.rhs(position[i]) -= stress.stress()[component[i]] * g[scalar[i]] * JxW;
              if (with_tangent)
                stress.add_tangent(g, n_scalar, JxW, scratch.work, scratch.blocks);
            }
          if (with_tangent)
            scatter_tangent_blocks(scratch.blocks, dof, position, part.K);
          part.valid = true;
      };
      const auto copier = [&](const NonlinearCellPart &part) { add_cell_part(part, with_tangent); };
      const NonlinearScratch  scratch(n_scalar, dofs_per_cell);
      const NonlinearCellPart part(dofs_per_cell);
      WorkStream::run(owned_cells.cbegin(), owned_cells.cend(), worker, copier, scratch, part);
      // The energy summed in the cells' order, whichever thread added which cell.
      for (const double e : cell_energy)
        local_energy += e;
      if (inverted)
        return false;

      add_elastic_faces(u_read, with_tangent, local_energy);
      return true;
    }

    template <typename Algebra>
    void LargeDeformationSolve<Algebra>::add_cell_part(const NonlinearCellPart &part, const bool with_tangent)
    {
      const unsigned int dofs_per_cell = reference.dofs_per_cell;
      if (!part.valid)
        return;
      cell_energy[part.cell] = part.energy;
      if (through_constraints[part.cell])
        {
          if (with_tangent)
            space.constraints.distribute_local_to_global(part.K, part.rhs, part.dof_indices, tangent, rhs);
          else
            space.constraints.distribute_local_to_global(part.rhs, part.dof_indices, rhs);
          return;
        }
      // No constraint to resolve (serial): the rows straight into the matrix, columns ascending.
      if constexpr (std::is_same_v<Algebra, SerialAlgebra>)
        {
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            rhs(part.dof_indices[i]) += part.rhs(i);
          if (with_tangent)
            assembly::add_sorted_cell_matrix(part.dof_indices, part.K, tangent);
        }
    }

    template <typename Algebra>
    void LargeDeformationSolve<Algebra>::add_elastic_faces(const VectorType &u_read, const bool with_tangent,
                                                           double &local_energy)
    {
      const auto        &fe            = space.dof_handler.get_fe();
      const unsigned int dofs_per_cell = fe.n_dofs_per_cell();
      FullMatrix<double>                   cell_K(dofs_per_cell, dofs_per_cell);
      Vector<double>                       cell_rhs(dofs_per_cell), cell_u(dofs_per_cell);
      std::vector<types::global_dof_index> dof_indices(dofs_per_cell);
      for (const auto &face : space.elastic_faces)
        {
          assembly::elastic_face_matrix(space.mapping, fe, face, cell_K);
          face.cell->get_dof_indices(dof_indices);
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            cell_u(i) = u_read(dof_indices[i]);
          cell_K.vmult(cell_rhs, cell_u);
          local_energy += 0.5 * (cell_u * cell_rhs);
          cell_rhs *= -1.;
          if (with_tangent)
            space.constraints.distribute_local_to_global(cell_K, cell_rhs, dof_indices, tangent, rhs);
          else
            space.constraints.distribute_local_to_global(cell_rhs, dof_indices, rhs);
        }
    }

    // CG on the tangent, preconditioned by the last factorization: while the part is near its linear
    // state the tangent is close to K, so a few iterations reach the tolerance. False where it stalls
    // (more than 40 iterations, or still above 1e-3 after 10) or meets a direction of non-positive
    // curvature (the caller factorizes, which tells a tangent that is not positive definite).
    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::preconditioned_cg(VectorType &du, const double tolerance)
    {
      typename Algebra::Inverse *preconditioner = tangent_factor ? tangent_factor.get() : space.linear_factorization;
      if (!space.use_cg || preconditioner == nullptr)
        return false;
      ++counts.cg_solves;
      VectorType r(rhs), z(rhs), p(rhs), Ap(rhs);
      du                    = 0.;
      const double b_norm   = rhs.l2_norm();
      const auto   precondition = [&] {
        z = r;
        preconditioner->solve_block(z.begin(), 1);
      };
      precondition();
      p         = z;
      double rz = r * z;
      for (unsigned int iteration = 1; iteration <= 40; ++iteration)
        {
          ++counts.cg_iterations;
          tangent.vmult(Ap, p);
          const double pAp = p * Ap;
          if (!(pAp > 0.))
            return false;
          const double alpha = rz / pAp;
          du.add(alpha, p);
          r.add(-alpha, Ap);
          const double relative = r.l2_norm() / b_norm;
          if (relative <= tolerance)
            return true;
          if (iteration >= 10 && relative > 1e-3)
            return false;
          precondition();
          const double rz_next = r * z;
          p.sadd(rz_next / rz, z);
          rz = rz_next;
        }
      return false;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::solve_tangent(VectorType &du, std::string &failure, const double tolerance)
    {
      Timer      timer;
      const bool solved = solve_tangent_system(du, failure, tolerance);
      counts.solve_seconds += timer.wall_time();
      return solved;
    }

    template <typename Algebra>
    bool LargeDeformationSolve<Algebra>::solve_tangent_system(VectorType &du, std::string &failure, const double tolerance)
    {
      if (preconditioned_cg(du, tolerance))
        {
          space.constraints.distribute(du);
          return true;
        }
      ++counts.factorizations;
      tangent_factor = factorize_tangent(tangent, modes);
      if (!tangent_factor)
        {
          failure = "the tangent stiffness is not positive definite (a limit point: buckling, snap-through "
                    "or a material instability)";
          return false;
        }
      du = rhs;
      tangent_factor->solve_block(du.begin(), 1);
      space.constraints.distribute(du);
      return true;
    }

    template class LargeDeformationSolve<SerialAlgebra>;
    template class LargeDeformationSolve<DistributedAlgebra>;
  } // namespace nonlinear
} // namespace modal_haptics
