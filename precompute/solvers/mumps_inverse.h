// The distributed space's direct solver: MUMPS's factorization of A = K - shift M, computed once
// and applied as x = A^-1 b (PARPACK's shift-invert operator and the static solves). Two wrappers:
// - MUMPS's own C interface (the default): its symmetric mode, L D L^T on the upper triangle (about half
//   the factor of an LU and half its flops), positive definite (no pivoting) when the shift is not
//   positive, general symmetric with pivoting otherwise (K - shift M indefinite above the first
//   eigenvalue);
// - Trilinos Amesos_Mumps through deal.II's SolverDirect: MUMPS's unsymmetric LU, kept as the peer
//   (Amesos_Mumps always calls MUMPS with SYM = 0: its symmetric mode is unreachable there).
// MUMPS's headers stay inside mumps_inverse.cc.
#pragma once

#include "solvers/factorization.h"
#include "parameters/scene_parameters.h"
#include "solvers/solver_choice.h"

#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace modal_haptics
{
  class DistributedInverse
  {
  public:
    virtual ~DistributedInverse() = default;
    // dst = A^-1 src (collective).
    virtual void vmult(dealii::TrilinosWrappers::MPI::Vector       &dst,
                       const dealii::TrilinosWrappers::MPI::Vector &src) const = 0;
    // columns[c] = A^-1 columns[c] for every c, in place (collective). MUMPS's symmetric path solves them as
    // one block of right-hand sides (MUMPS reads its factor once for all); Amesos' one by one.
    virtual void solve_columns(std::vector<dealii::TrilinosWrappers::MPI::Vector> &columns) const;
    // The same on count columns of this process's rows stored one after the other (column-major,
    // as the block eigensolver keeps them), in place (collective).
    virtual void solve_block(double *columns, int count) const = 0;
    // The number of A's negative eigenvalues (the inertia of an L D L^T factorization: MUMPS's
    // INFOG(12) in its symmetric indefinite mode), or -1 where the factorization does not tell.
    virtual long negative_eigenvalues() const { return -1; }
  };

  // Factorizes A (collective) where place(prediction) puts the factor once MUMPS's analysis has
  // predicted what it needs (solver_choice.h chooses): in memory, on disk in 'directory' (empty:
  // $MUMPS_OOC_TMPDIR, $TMPDIR or /tmp), or nowhere (nullptr: nothing factorized). place is called
  // once, before the factorization (minutes at 10^6 DoFs). The LU path (Amesos) predicts nothing (-1)
  // and keeps its factor in memory. stats gets the method, the time and, for the symmetric path, the
  // factor's entries (MUMPS INFOG(29)). positive_definite: A is (K with a shift <= 0).
  std::unique_ptr<DistributedInverse>
  make_mumps_inverse(const dealii::TrilinosWrappers::SparseMatrix &A, DistributedFactorizationKind kind,
                     bool positive_definite, const std::string &directory, FactorizationStatistics &stats,
                     const std::function<solver_choice::Placement(const solver_choice::MumpsPrediction &)> &place);
} // namespace modal_haptics
