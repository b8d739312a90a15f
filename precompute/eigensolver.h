// The generalized eigenproblem K phi = lambda M phi for the lowest modes: ARPACK (dsaupd/dseupd,
// mode 3: shift-invert, M inner product) over a sparse direct factorization of K - sigma M.
#pragma once

#include "factorization.h"

#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <vector>

namespace modal_haptics
{
  struct EigenSolution
  {
    std::vector<double>                 eigenvalues;  // ascending [rad^2/s^2]
    std::vector<dealii::Vector<double>> eigenvectors; // M-orthonormal
    unsigned int n_operator_applications = 0;         // solves with the factorization
    unsigned int n_restarts              = 0;         // ARPACK's implicit restarts
    double       arpack_seconds          = 0.;        // wall time inside the Lanczos iteration
  };

  // Computes the n_modes eigenpairs closest to the shift (rad^2/s^2) with the factorization of
  // K - shift M. ARPACK errors are user-visible (AssertThrow), also in Release builds.
  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &shifted_inverse,
                                   double                              shift,
                                   unsigned int                        n_modes,
                                   double                              tolerance,
                                   bool                                verbose);

  // The same spectral transformation with a block Krylov method (block_eigensolver.cc): blocks of
  // block_size right-hand sides per solve, thick restarts. Converged when every wanted Ritz pair's residual
  // ||OP z - theta z||_M / theta is below tolerance.
  EigenSolution solve_block_shift_invert(const dealii::SparseMatrix<double> &M,
                                         Factorization                      &shifted_inverse,
                                         double                              shift,
                                         unsigned int                        n_modes,
                                         unsigned int                        block_size,
                                         double                              tolerance,
                                         bool                                verbose);

  struct EigenSelfCheck
  {
    double orthonormality_error   = 0.; // max |Phi^T M Phi - I|
    double max_relative_residual  = 0.; // max ||K phi - lambda M phi|| / ||lambda M phi||
  };

  EigenSelfCheck check_eigenpairs(const dealii::SparseMatrix<double> &K,
                                  const dealii::SparseMatrix<double> &M,
                                  const EigenSolution                &solution);
} // namespace modal_haptics
