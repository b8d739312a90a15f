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
#include <utility>
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
    unsigned int n_runs             = 1;              // ARPACK: runs, each in the complement of the earlier ones' modes
  };

  // The report's words for the block Krylov method: "block Krylov (shift-invert, blocks of 4)", and
  // whether M V was recomputed instead of stored.
  std::string block_krylov_method(unsigned int block_size, const EigenSolution &solution);

  // When an eigensolve may stop before its n_modes: the mode-selection rule keeps the lowest
  // max(minimum, number below the cut-off) modes, so its count is decided once the lowest 'minimum'
  // have converged and so has one above the cut-off (every later mode lies above it too): then the
  // solver stops instead of converging the rest, which the cut-off would drop. Shift-invert converges
  // the modes nearest the shift first, and the shift lies below the first mode ('Modes/Shift';
  // CHOLMOD's Cholesky of K - shift M fails otherwise, MUMPS's L D L^T counts the modes below it
  // before the iteration, the distributed LU path refuses a computed mode below it), so the nearest
  // are the lowest: the trust every count of computed modes rests on. (A shift inside the spectrum
  // would converge modes on both sides of it first: a converged mode above the cut-off would then
  // not rule out an unfound one below.) An infinite cut-off (rule 'none', modal-study) computes all n_modes. One place for the
  // rule: the block Krylov method asks decided_count as its Ritz values converge; ARPACK, PARPACK and
  // LOBPCG, which must be told a count before they start, ask next_batch between their runs.
  struct CutOffStop
  {
    unsigned int minimum            = 0;
    double       cut_off_eigenvalue = std::numeric_limits<double>::infinity(); // (2 pi f_cut)^2 [rad^2/s^2]

    // How many of the lowest eigenvalues (ascending, at least n_modes of them or all there are)
    // decide the count, at most n_modes.
    unsigned int decided_count(const std::vector<double> &lowest, unsigned int n_modes) const;

    // For a solver that seeks a given count per run, each run in the M-orthogonal complement of the
    // modes found before: how many more of the lowest modes to seek, given the found ones'
    // eigenvalues (ascending); 0 once they decide the count or n_modes are found. The first run
    // seeks the floor and a margin (all n_modes under an infinite cut-off), each later one doubles
    // the found count, at most up to n_modes. Each run builds its own basis, so the runs cost more
    // than one run for their total: ARPACK on the 5 mm P2 cantilever (floor 10, at most 50) took 41
    // solves where the first run decided (one run for 50: 111), 96 where the second did, 163 where
    // all 50 lie below the cut-off.
    unsigned int next_batch(const std::vector<double> &found, unsigned int n_modes) const;
  };

  // The modes found by an eigensolver's runs so far, and the projection onto their M-orthogonal
  // complement, y <- y - Phi (M Phi)^T y, where a later run seeks the next modes
  // (CutOffStop::next_batch): ARPACK's shift-invert operator followed by it has the same eigenpairs
  // in the complement and 0 on the found modes (never the largest, so never found again), and it
  // stays M-symmetric (to the found modes' residuals). For deal.II's serial vectors and Trilinos'
  // distributed ones (whose dot products are sums over the processes).
  template <typename VectorType>
  class FoundModes
  {
  public:
    // Appends an eigenpair: phi projected onto the complement of the earlier ones (to rounding it
    // lies there already) and normalized in M again, so that round-off does not accumulate.
    template <typename MatrixType>
    void add(const double lambda, VectorType phi, const MatrixType &M)
    {
      project(phi);
      VectorType M_phi(phi);
      M.vmult(M_phi, phi);
      const double norm = std::sqrt(phi * M_phi);
      phi /= norm;
      M_phi /= norm;
      eigenvalues.push_back(lambda);
      modes.push_back(std::move(phi));
      mass_images.push_back(std::move(M_phi));
    }

    void project(VectorType &y) const
    {
      for (std::size_t i = 0; i < modes.size(); ++i)
        y.add(-(mass_images[i] * y), modes[i]);
    }

    std::size_t size() const { return modes.size(); }

    // The eigenvalues found, ascending (the runs' orders interleave where a run ends inside a cluster).
    std::vector<double> ascending() const
    {
      std::vector<double> sorted = eigenvalues;
      std::sort(sorted.begin(), sorted.end());
      return sorted;
    }

    // The eigenpairs, eigenvalues ascending, moved out (ARPACK does not promise an order).
    void take_ascending(std::vector<double> &lambda, std::vector<VectorType> &phi)
    {
      std::vector<std::size_t> order(eigenvalues.size());
      for (std::size_t i = 0; i < order.size(); ++i)
        order[i] = i;
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return eigenvalues[a] < eigenvalues[b]; });
      for (const std::size_t i : order)
        {
          lambda.push_back(eigenvalues[i]);
          phi.push_back(std::move(modes[i]));
        }
      *this = {};
    }

  private:
    std::vector<double>     eigenvalues;
    std::vector<VectorType> modes, mass_images;
  };

  // Computes the n_modes eigenpairs closest to the shift (rad^2/s^2) with the factorization of
  // K - shift M, ascending; fewer where 'stop' decides the count earlier: ARPACK runs of
  // stop.next_batch modes, each in the M-orthogonal complement of the earlier runs' modes (the last
  // run's modes beyond the decided count are returned too). ARPACK errors are user-visible
  // (AssertThrow), also in Release builds.
  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &shifted_inverse,
                                   double                              shift,
                                   unsigned int                        n_modes,
                                   double                              tolerance,
                                   bool                                verbose,
                                   const CutOffStop                   &stop = {});

  // The report's words for ARPACK's runs after the first: "" for one, else ", 2 runs, each in the
  // M-orthogonal complement of the earlier ones' modes" (serial ARPACK and PARPACK alike).
  std::string arpack_runs(unsigned int runs);

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
