// The generalized eigenproblem K phi = lambda M phi for the lowest modes: ARPACK (dsaupd/dseupd,
// mode 3: shift-invert, M inner product) over a sparse direct factorization of K - sigma M.
#pragma once

#include "solvers/factorization.h"

#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace modal_haptics
{
  struct EigenSolution
  {
    std::vector<double>                 eigenvalues;  // ascending [rad^2/s^2]
    std::vector<dealii::Vector<double>> eigenvectors; // M-orthonormal
    unsigned int n_operator_applications = 0;         // solves with the factorization
    unsigned int n_restarts              = 0;         // ARPACK's implicit restarts
    double       eigensolve_iteration_seconds = 0.; // wall time inside the iteration (ARPACK's Lanczos or block Krylov)
    double       mass_product_seconds    = 0.;        // block Krylov: the products with M, in eigensolve_iteration_seconds
    double       orthogonalization_seconds = 0.;      // block Krylov: Gram-Schmidt + Cholesky QR, in eigensolve_iteration_seconds
    bool         mass_images_stored = true;           // block Krylov: M V kept beside V and OP V
  };

  // The report's words for the block Krylov method: "block Krylov (shift-invert, blocks of 4)", and
  // whether M V was recomputed instead of stored.
  std::string block_krylov_method(unsigned int block_size, const EigenSolution &solution);

  // Computes the n_modes eigenpairs closest to the shift (rad^2/s^2) with the factorization of
  // K - shift M. ARPACK errors are user-visible (AssertThrow), also in Release builds.
  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &shifted_inverse,
                                   double                              shift,
                                   unsigned int                        n_modes,
                                   double                              tolerance,
                                   bool                                verbose);

  // What the block Krylov eigensolver needs of its problem, on this process's rows: M times a block,
  // the solves with K - shift M, and sums over the processes. Blocks are column-major, local_rows()
  // long per column; every n-long product is local, and only the small inner-product matrices are
  // summed, so the same iteration runs serially (CHOLMOD) and distributed (MUMPS).
  class BlockEigenOperators
  {
  public:
    virtual ~BlockEigenOperators() = default;
    virtual std::size_t local_rows() const  = 0;
    virtual std::size_t global_rows() const = 0;
    // dst = M src for count columns (dst does not alias src).
    virtual void multiply_by_mass(const double *src, double *dst, int count) = 0;
    // columns = (K - shift M)^-1 columns, in place, count at once (one pass over the factor).
    virtual void solve(double *columns, int count) = 0;
    // values summed over the processes, in place, the same sums on every process (collective).
    virtual void sum_over_processes(double *values, std::size_t count) const = 0;
    // Differs between processes, so that their parts of a random start block differ.
    virtual unsigned int process() const = 0;
  };

  // When the block Krylov eigensolve may stop before its n_modes: the mode-selection rule keeps the
  // lowest max(minimum, number below the cut-off) modes, so its count is decided once the lowest
  // 'minimum' have converged and so has one above the cut-off (every later mode lies above it too):
  // then the iteration stops instead of converging the rest, which the cut-off would drop. Shift-invert
  // converges the modes nearest the shift (the lowest) first, the trust every count of computed
  // modes rests on. An infinite cut-off (rule 'none', modal-study) computes all n_modes.
  struct CutOffStop
  {
    unsigned int minimum            = 0;
    double       cut_off_eigenvalue = std::numeric_limits<double>::infinity(); // (2 pi f_cut)^2 [rad^2/s^2]

    // How many of the lowest eigenvalues (ascending, at least n_modes of them or all there are)
    // decide the count, at most n_modes.
    unsigned int decided_count(const std::vector<double> &lowest, unsigned int n_modes) const;
  };

  // The same spectral transformation with a block Krylov method (block_eigensolver.cc): blocks of
  // block_size right-hand sides per solve, thick restarts. Converged when every wanted Ritz pair's residual
  // ||OP z - theta z||_M / theta is below tolerance. The eigenvectors hold this process's rows. The
  // basis keeps M V beside V and OP V when the three fit memory_limit_bytes on every process (else
  // M V is recomputed where it is needed: a third less memory, more M products).
  EigenSolution solve_block_shift_invert(BlockEigenOperators &operators,
                                         double               shift,
                                         unsigned int         n_modes,
                                         unsigned int         block_size,
                                         double               tolerance,
                                         double               memory_limit_bytes,
                                         bool                 verbose,
                                         const CutOffStop    &stop = {});

  // The serial case: M's products on deal.II's threads, the solves by the factorization.
  EigenSolution solve_block_shift_invert(const dealii::SparseMatrix<double> &M,
                                         Factorization                      &shifted_inverse,
                                         double                              shift,
                                         unsigned int                        n_modes,
                                         unsigned int                        block_size,
                                         double                              tolerance,
                                         double                              memory_limit_bytes,
                                         bool                                verbose,
                                         const CutOffStop                   &stop = {});

  // For deal.II's serial and Trilinos' distributed matrices and vectors alike. A residual is relative
  // to max(|lambda|, lambda_floor) ||M phi||: rigid-body modes (lambda = 0) are measured against the
  // first elastic eigenvalue.
  template <typename MatrixType, typename VectorType>
  EigenSelfCheck check_eigenpairs(const MatrixType &K, const MatrixType &M, const std::vector<double> &eigenvalues,
                                  const std::vector<VectorType> &phi, const double lambda_floor = 0.)
  {
    EigenSelfCheck          check;
    const unsigned int      r = phi.size();
    std::vector<VectorType> M_phi(r);
    VectorType              K_phi;
    for (unsigned int i = 0; i < r; ++i)
      {
        M_phi[i].reinit(phi[i]);
        M.vmult(M_phi[i], phi[i]);
        K_phi.reinit(phi[i]);
        K.vmult(K_phi, phi[i]);
        const double lambda = eigenvalues[i];
        const double scale  = std::max(std::abs(lambda), lambda_floor) * M_phi[i].l2_norm();
        K_phi.add(-lambda, M_phi[i]);
        check.max_relative_residual = std::max(check.max_relative_residual, K_phi.l2_norm() / (scale > 0. ? scale : 1.));
      }
    // M is symmetric: the lower triangle of Phi^T M Phi is the whole of it (to rounding).
    for (unsigned int i = 0; i < r; ++i)
      for (unsigned int j = 0; j <= i; ++j)
        check.orthonormality_error =
          std::max(check.orthonormality_error, std::abs(phi[i] * M_phi[j] - (i == j ? 1. : 0.)));
    return check;
  }
} // namespace modal_haptics
