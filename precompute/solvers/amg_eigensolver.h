// The path that never factors K ('Modes/Eigensolver = lobpcg-amg'): the lowest modes by LOBPCG
// (Trilinos Anasazi) preconditioned by smoothed-aggregation AMG (Trilinos ML) whose near-null space
// is the six rigid-body motions, and the static solves by block CG (Trilinos Belos) with the same AMG,
// deflated by the computed modes. Memory grows about linearly with the DoFs, where the
// direct factorization grows as DoFs^1.3 (docs/cluster.md).
//
// It acts on A = K - shift M (shift <= 0, positive definite: a free part needs a negative shift, as
// on the direct path) and presents itself as a Factorization: the static correction's refinement
// against K (SerialSpace::solve_static) is the same on both paths. The distributed space uses the
// same object on its Trilinos matrices (every process its own rows). Trilinos' solver headers stay
// inside amg_eigensolver.cc (compile time).
#pragma once

#include "solvers/eigensolver.h"
#include "solvers/factorization.h"

#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <mpi.h>

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <memory>
#include <vector>

namespace dealii::TrilinosWrappers
{
  class SparseMatrix;
  namespace MPI
  {
    class Vector;
  }
} // namespace dealii::TrilinosWrappers

namespace modal_haptics
{
  // What the path adds to FactorizationStatistics (whose analyze_seconds is the AMG's setup, with
  // the Trilinos copies of K and M, and solve_seconds the CG solves).
  struct AmgSolverStatistics
  {
    unsigned int eigensolver_iterations  = 0;  // LOBPCG's, over all its runs
    unsigned int modes_per_run           = 0;  // the most modes one LOBPCG run sought
    unsigned int n_lobpcg_runs           = 0;
    unsigned int n_cg_solves             = 0;  // columns solved
    unsigned int max_cg_iterations       = 0;  // of any block CG (its block iterations)
    double       mean_cg_iterations      = 0.; // block iterations per column's solve
    unsigned int deflation_modes         = 0;  // the modes the static solves are deflated by
    double       deflation_seconds       = 0.; // forming A Z and Z^T A Z
  };

  // A higher-order space's vertex (P1) space, where the AMG starts (amg_eigensolver.cc,
  // VertexTwoLevel): smoothed aggregation on the P2 nodes themselves is a weak preconditioner (91
  // LOBPCG iterations at 263k P2 DoFs against 30 for P1, docs/performance.md).
  struct VertexSpaceTransfer
  {
    // The interpolation of a vertex-space field into the space (exact on affine tets): this
    // process's rows of the space, the vertex space's DoFs as columns.
    std::shared_ptr<dealii::TrilinosWrappers::SparseMatrix> prolongation;
    // The six rigid-body motions at this process's vertex DoFs, one column after the other.
    std::vector<double> near_null_space;
    bool                node_blocked = false; // DoFs 3k, 3k+1, 3k+2 are one vertex's x, y, z
  };

  // Whether DoFs 3k, 3k+1, 3k+2 are the x, y, z of one support point on every process's cells
  // (deal.II's numbering of an FESystem of 3 components without renumbering), which lets ML
  // aggregate nodes rather than single DoFs. Collective over comm.
  bool node_blocked(const dealii::DoFHandler<3> &dof_handler, MPI_Comm comm);

  // The vertex space of a space of higher degree on the same mesh (linear elements, 3 components):
  // the interpolation into the space, this process's rows (dof_handler's locally owned DoFs; all
  // of them serially), and the rigid-body motions at the vertices, zero where the space's DoF at
  // that vertex is constrained (as the space's own near-null space is). Collective over comm.
  VertexSpaceTransfer make_vertex_space_transfer(const dealii::DoFHandler<3>             &dof_handler,
                                                 const dealii::Mapping<3>                &mapping,
                                                 const dealii::AffineConstraints<double> &constraints,
                                                 MPI_Comm                                 comm);

  class AmgShiftedInverse : public Factorization
  {
  public:
    // rigid_body_motions: the six motions as DoF fields (the AMG's near-null space); constrained:
    // the DoFs that are zero in every field (their rows of M are zero). node_blocked: DoFs 3k, 3k+1,
    // 3k+2 are the x, y, z of one support point (deal.II's numbering of an FESystem without
    // renumbering), which lets ML aggregate nodes rather than single DoFs. vertex_space: for
    // elements of degree > 1, where the AMG works (null for linear elements: on the space itself).
    AmgShiftedInverse(const dealii::SparseMatrix<double>           &K,
                      const dealii::SparseMatrix<double>           &M,
                      double                                        shift,
                      const std::array<dealii::Vector<double>, 6> &rigid_body_motions,
                      const std::vector<unsigned int>              &constrained,
                      bool                                          node_blocked,
                      const VertexSpaceTransfer                    *vertex_space);
    // Distributed: K and M as the distributed space holds them (referenced, not copied, unless
    // shifted); near_null_space: the six rigid-body motions at this process's rows, one column of
    // n_local after the other; constrained: this process's constrained rows, as local indices.
    AmgShiftedInverse(const dealii::TrilinosWrappers::SparseMatrix &K,
                      const dealii::TrilinosWrappers::SparseMatrix &M,
                      double                                        shift,
                      std::vector<double>                           near_null_space,
                      const std::vector<unsigned int>              &constrained,
                      bool                                          node_blocked,
                      const VertexSpaceTransfer                    *vertex_space);
    ~AmgShiftedInverse() override;

    // The n_modes lowest eigenpairs of K phi = lambda M phi, M-orthonormal, ascending (each vector
    // holds this process's rows), or fewer once they decide the cut-off's count ('stop'). Converged
    // when every pair's ||A x - theta M x|| / (theta ||M x||) is below tolerance (collective). At
    // most modes_per_run modes per LOBPCG run (0: all at once if that fits half the available
    // memory, else as many as fit) and at most stop.next_batch, later runs in the complement of the
    // earlier ones' modes; a run stops as soon as its converged lowest pairs decide the count.
    // progress, when set, gets a line every 30 s, and so do the static solves' block CGs after it.
    EigenSolution lowest_modes(unsigned int n_modes, double tolerance, unsigned int modes_per_run,
                               const std::function<void(const std::string &)> &progress,
                               const CutOffStop                                &stop = {});

    // Later static solves are deflated by the modes' span (amg_eigensolver.cc, Deflation): their
    // preconditioner is exact on it and CG works on the rest of the spectrum only. The modes are
    // copied (with A times them: two n x n_modes blocks); serial or this process's rows.
    void deflate_by_modes(const std::vector<dealii::Vector<double>> &modes);
    void deflate_by_modes(const std::vector<dealii::TrilinosWrappers::MPI::Vector> &modes);

    // The most right-hand sides (at most 'wanted', at least 1) that one block CG may take so that
    // its work space fits half of this process's share of the memory available now (collective).
    unsigned int columns_fitting_one_solve(unsigned int wanted) const;

    // A X = B by AMG-preconditioned block CG (Trilinos Belos) on all the columns at once, each to
    // a relative residual of 1e-12 (as the direct path's refined solves).
    void solve_block(double *columns, unsigned int n_rhs) override;

    // The same for the distributed space: columns[c] = A^-1 columns[c], in place (collective).
    void solve_columns(std::vector<dealii::TrilinosWrappers::MPI::Vector> &columns);

    const AmgSolverStatistics &amg_statistics() const;

    // How lowest_modes found the modes, for the report: LOBPCG + AMG, and its runs if several.
    std::string eigensolver_method() const;

    // The preconditioner as a log line names it: "AMG (ML, rigid-body near-null space)", for a P2
    // space with its smoother's interval.
    std::string preconditioner_name() const;

  private:
    void describe(bool node_blocked, double setup_seconds);

    struct Impl;
    std::unique_ptr<Impl> impl;
  };
} // namespace modal_haptics
