// A block shift-invert Krylov eigensolver with thick restarts: the same spectral transformation
// as ARPACK's mode 3, but every application of (K - sigma M)^-1 M is done on a block of vectors.
//
// Why: the supernodal triangular solves are memory-bound (they read the whole factor for one
// vector); a block of right-hand sides reads it once for all of them. ARPACK's reverse
// communication hands out one vector at a time. Larger blocks are cheaper per vector but build a
// Krylov space of lower degree for the same size, so they need more vectors: 4 was the best
// trade on our parts (benchmarks/eigensolver/README.md).
//
// Method: V is an M-orthonormal basis, W = OP V its images (OP = (K - sigma M)^-1 M), so that the
// Rayleigh-Ritz projection of OP onto span V is H = V^T M W = (M V)^T W, exact for any basis. The
// basis grows a block at a time (the M-orthogonalized images of the newest block, classical
// Gram-Schmidt twice); when full, the wanted Ritz vectors are kept (a thick restart: V Z, W Z and
// M V Z need no new solve) and the residuals of the unconverged ones seed the next block.
#include "eigensolver.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <sstream>
#include <string>

extern "C"
{
  void dgemm_(const char *, const char *, const int *, const int *, const int *, const double *, const double *,
              const int *, const double *, const int *, const double *, double *, const int *);
  void dsyev_(const char *, const char *, const int *, double *, const int *, double *, double *, const int *, int *);
  void dpotrf_(const char *, const int *, double *, const int *, int *);
  void dtrsm_(const char *, const char *, const char *, const char *, const int *, const int *, const double *,
              const double *, const int *, double *, const int *);
}

namespace modal_haptics
{
  using dealii::ExcMessage;

  namespace
  {
    // Column-major dense blocks: C = alpha op(A) op(B) + beta C.
    void gemm(const char ta, const char tb, const int m, const int n, const int k, const double alpha, const double *A,
              const int lda, const double *B, const int ldb, const double beta, double *C, const int ldc)
    {
      dgemm_(&ta, &tb, &m, &n, &k, &alpha, A, &lda, B, &ldb, &beta, C, &ldc);
    }

    class BlockKrylov
    {
    public:
      BlockKrylov(const dealii::SparseMatrix<double> &M, Factorization &inverse, unsigned int n_modes,
                  unsigned int block_size, double tolerance, bool verbose)
        : M(M)
        , inverse(inverse)
        , n(M.m())
        , nev(n_modes)
        , block(block_size)
        , tolerance(tolerance)
        , verbose(verbose)
      {
        // Three times the wanted count, whole blocks: with blocks of 4 this converged 50 modes in one
        // cycle (160 solved vectors, ARPACK: 141 single solves) on the FACTS plate.
        capacity = std::min<int>(n - 1, block * ((3 * nev + block - 1) / block + 1));
        AssertThrow(capacity > nev + block,
                    ExcMessage("Too few unknowns (" + std::to_string(n) + ") for " + std::to_string(nev) + " modes."));
        V.assign(std::size_t(n) * capacity, 0.);
        MV.assign(std::size_t(n) * capacity, 0.);
        W.assign(std::size_t(n) * capacity, 0.);
      }

      EigenSolution solve(const double shift)
      {
        dealii::Timer timer;
        std::vector<double> seed(std::size_t(n) * block);
        std::mt19937_64 random(20261122);
        std::uniform_real_distribution<double> uniform(-1., 1.);
        for (double &x : seed)
          x = uniform(random);
        // Start from OP applied to a random block: it lies in the range of OP (zero on clamped rows).
        apply_operator(seed.data(), seed.data(), block);
        int size = append_block(seed.data(), block, 0);

        EigenSolution solution;
        std::vector<double> theta, Z;
        for (unsigned int cycle = 0; cycle < 50; ++cycle)
          {
            // Grow the basis: the images of the newest block, orthogonalized, are the next block.
            while (size + block <= capacity)
              {
                const int newest = size - block;
                std::copy(W.begin() + std::size_t(newest) * n, W.begin() + std::size_t(size) * n, seed.begin());
                const int added = append_block(seed.data(), block, size);
                if (added == 0)
                  break;
                size += added;
              }
            rayleigh_ritz(size, theta, Z);
            const int converged = count_converged(size, theta, Z);
            if (verbose)
              std::cout << "[eigensolve]   cycle " << cycle + 1 << ": basis " << size << ", " << converged << " of "
                        << nev << " converged, " << solved << " vectors solved, " << timer.wall_time() << " s"
                        << std::endl;
            if (converged >= nev)
              break;
            AssertThrow(cycle + 1 < 50, ExcMessage(not_converged_message(converged, shift, theta)));
            size = restart(size, theta, Z);
          }

        solution.n_operator_applications = solved;
        for (int i = 0; i < nev; ++i)
          {
            solution.eigenvalues.push_back(shift + 1. / theta[i]);
            dealii::Vector<double> phi(n);
            gemm('N', 'N', n, 1, size, 1., V.data(), n, &Z[std::size_t(i) * size], size, 0., phi.data(), n);
            solution.eigenvectors.push_back(std::move(phi));
          }
        solution.arpack_seconds = timer.wall_time();
        return solution;
      }

    private:
      // What was found when the iteration gives up: the converged count and their frequencies, so
      // that the user can ask for fewer modes or a looser tolerance instead of losing the run silently.
      std::string not_converged_message(const int converged, const double shift, const std::vector<double> &theta) const
      {
        std::ostringstream message;
        message << "The block eigensolver did not converge in 50 restarts: " << converged << " of " << nev
                << " modes met 'Modes/Tolerance' = " << tolerance << ".";
        if (converged > 0)
          {
            message << " Converged frequencies [Hz]:";
            for (int i = 0; i < converged; ++i)
              message << ' ' << std::sqrt(std::max(0., shift + 1. / theta[i])) / (2. * M_PI);
          }
        message << " Ask for fewer modes ('Modes/Maximum number of modes') or a looser tolerance.";
        return message.str();
      }

      // dst = (K - sigma M)^-1 M src for count columns (dst may alias src).
      void apply_operator(const double *src, double *dst, const int count)
      {
        std::vector<double> Msrc(std::size_t(n) * count);
        multiply_by_mass(src, Msrc.data(), count);
        inverse.solve_block(Msrc.data(), count);
        std::copy(Msrc.begin(), Msrc.end(), dst);
        solved += count;
      }

      void multiply_by_mass(const double *src, double *dst, const int count) const
      {
        dealii::Vector<double> x(n), y(n);
        for (int c = 0; c < count; ++c)
          {
            std::copy(src + std::size_t(c) * n, src + std::size_t(c + 1) * n, x.begin());
            M.vmult(y, x);
            std::copy(y.begin(), y.end(), dst + std::size_t(c) * n);
          }
      }

      // M-orthogonalizes X (n x count) against the first 'size' basis vectors and within itself,
      // appends it to V (with M V and W = OP V) and returns how many columns were added (0 when the
      // block collapsed: the Krylov space is exhausted).
      int append_block(double *X, const int count, const int size)
      {
        std::vector<double> C(std::size_t(std::max(size, 1)) * count), MX(std::size_t(n) * count), G(count * count);
        // Two passes of classical Gram-Schmidt and Cholesky QR; M X is computed once and then
        // updated with the same dense operations as X (M V is stored for that).
        for (int pass = 0; pass < 2; ++pass)
          {
            if (size > 0)
              {
                gemm('T', 'N', size, count, n, 1., MV.data(), n, X, n, 0., C.data(), size);
                gemm('N', 'N', n, count, size, -1., V.data(), n, C.data(), size, 1., X, n);
                if (pass > 0)
                  gemm('N', 'N', n, count, size, -1., MV.data(), n, C.data(), size, 1., MX.data(), n);
              }
            if (pass == 0)
              multiply_by_mass(X, MX.data(), count);
            // Cholesky QR in the M inner product: X^T M X = R^T R, X <- X R^-1.
            gemm('T', 'N', count, count, n, 1., X, n, MX.data(), n, 0., G.data(), count);
            int info = 0;
            dpotrf_("U", &count, G.data(), &count, &info);
            if (info != 0)
              return 0;
            const double one = 1.;
            dtrsm_("R", "U", "N", "N", &n, &count, &one, G.data(), &count, X, &n);
            dtrsm_("R", "U", "N", "N", &n, &count, &one, G.data(), &count, MX.data(), &n);
          }
        std::copy(X, X + std::size_t(n) * count, V.begin() + std::size_t(size) * n);
        std::copy(MX.begin(), MX.end(), MV.begin() + std::size_t(size) * n);
        apply_operator(X, &W[std::size_t(size) * n], count);
        return count;
      }

      // H = (M V)^T W, symmetrized; its eigenpairs, largest theta first.
      void rayleigh_ritz(const int size, std::vector<double> &theta, std::vector<double> &Z) const
      {
        Z.assign(std::size_t(size) * size, 0.);
        gemm('T', 'N', size, size, n, 1., MV.data(), n, W.data(), n, 0., Z.data(), size);
        for (int i = 0; i < size; ++i)
          for (int j = 0; j < i; ++j)
            Z[i + std::size_t(j) * size] = Z[j + std::size_t(i) * size] =
              0.5 * (Z[i + std::size_t(j) * size] + Z[j + std::size_t(i) * size]);
        std::vector<double> ascending(size);
        int                 lwork = -1, info = 0;
        double              query = 0.;
        dsyev_("V", "U", &size, Z.data(), &size, ascending.data(), &query, &lwork, &info);
        lwork = int(query);
        std::vector<double> work(lwork);
        dsyev_("V", "U", &size, Z.data(), &size, ascending.data(), work.data(), &lwork, &info);
        AssertThrow(info == 0, ExcMessage("LAPACK's dsyev failed in the Rayleigh-Ritz step."));
        // Reverse: largest theta (eigenvalue closest to the shift) first.
        theta.assign(ascending.rbegin(), ascending.rend());
        std::vector<double> reversed(Z.size());
        for (int i = 0; i < size; ++i)
          std::copy(Z.begin() + std::size_t(size - 1 - i) * size, Z.begin() + std::size_t(size - i) * size,
                    reversed.begin() + std::size_t(i) * size);
        Z.swap(reversed);
      }

      // Residuals r_i = W z_i - theta_i V z_i of the OP eigenproblem, in the M norm, relative to theta_i.
      std::vector<double> residual_norms(const int size, const std::vector<double> &theta, const std::vector<double> &Z,
                                         const int count, std::vector<double> &R) const
      {
        R.assign(std::size_t(n) * count, 0.);
        gemm('N', 'N', n, count, size, 1., W.data(), n, Z.data(), size, 0., R.data(), n);
        std::vector<double> VZ(std::size_t(n) * count);
        gemm('N', 'N', n, count, size, 1., V.data(), n, Z.data(), size, 0., VZ.data(), n);
        for (int c = 0; c < count; ++c)
          for (int i = 0; i < n; ++i)
            R[std::size_t(c) * n + i] -= theta[c] * VZ[std::size_t(c) * n + i];
        std::vector<double> MR(std::size_t(n) * count), norms(count);
        multiply_by_mass(R.data(), MR.data(), count);
        for (int c = 0; c < count; ++c)
          {
            double s = 0.;
            for (int i = 0; i < n; ++i)
              s += R[std::size_t(c) * n + i] * MR[std::size_t(c) * n + i];
            norms[c] = std::sqrt(std::max(s, 0.)) / std::abs(theta[c]);
          }
        return norms;
      }

      int count_converged(const int size, const std::vector<double> &theta, const std::vector<double> &Z)
      {
        const auto norms = residual_norms(size, theta, Z, nev, residuals);
        int        converged = 0;
        while (converged < nev && norms[converged] <= tolerance)
          ++converged;
        first_unconverged = converged;
        return converged;
      }

      // Keeps the nev + block best Ritz vectors (no solve needed: OP is linear) and seeds the next
      // block with the residuals of the first unconverged ones.
      int restart(const int size, const std::vector<double> &theta, const std::vector<double> &Z)
      {
        const int keep = std::min(size - block, nev + block);
        std::vector<double> scratch(std::size_t(n) * keep);
        for (auto *basis : {&V, &MV, &W})
          {
            gemm('N', 'N', n, keep, size, 1., basis->data(), n, Z.data(), size, 0., scratch.data(), n);
            std::copy(scratch.begin(), scratch.end(), basis->begin());
          }
        (void)theta;
        const int seeds = std::min(block, nev - first_unconverged);
        std::vector<double> seed(residuals.begin() + std::size_t(first_unconverged) * n,
                                 residuals.begin() + std::size_t(first_unconverged + seeds) * n);
        return keep + append_block(seed.data(), seeds, keep);
      }

      const dealii::SparseMatrix<double> &M;
      Factorization                      &inverse;
      const int                           n, nev, block;
      const double                        tolerance;
      const bool                          verbose;
      int                                 capacity = 0;
      unsigned int                        solved   = 0;
      int                                 first_unconverged = 0;
      std::vector<double>                 V, MV, W, residuals;
    };
  } // namespace

  EigenSolution solve_block_shift_invert(const dealii::SparseMatrix<double> &M,
                                         Factorization                      &shifted_inverse,
                                         const double                        shift,
                                         const unsigned int                  n_modes,
                                         const unsigned int                  block_size,
                                         const double                        tolerance,
                                         const bool                          verbose)
  {
    BlockKrylov solver(M, shifted_inverse, n_modes, block_size, tolerance, verbose);
    return solver.solve(shift);
  }
} // namespace modal_haptics
