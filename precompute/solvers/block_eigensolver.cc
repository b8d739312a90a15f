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
// Gram-Schmidt twice, then Cholesky QR twice); when full, the wanted Ritz vectors are kept (a
// thick restart: V Z, W Z and M V Z need no new solve) and the residuals of the unconverged ones
// seed the next block. Before the first restart the basis is a block Krylov space: the Gram-Schmidt
// coefficients give the Ritz residuals for free (ARPACK's Ritz estimates), so the growth stops at
// the first block where every wanted pair has converged (155 instead of 163 solved vectors on the
// FACTS plate), and the true residuals confirm it.
//
// Cost: every dense operation is a GEMM on the contiguous column-major bases, and M is applied to
// a whole block at once (one pass over M for all columns, M X of the newest block reused as the
// right-hand side of its solve): one M product per solved vector plus the residuals' per cycle.
// Where V, M V and W do not fit the memory limit (10^6 DoFs on one machine) M V is not stored: the
// Gram-Schmidt passes multiply the block by M instead (three M products per block instead of one)
// and the Rayleigh-Ritz step forms V^T (M W).
#include "solvers/eigensolver.h"

#include "solvers/blas_lapack.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/timer.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <sstream>
#include <string>

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

    // M in compressed rows, applied to a block of columns at once (one pass over M for all of
    // them; deal.II's vmult reads M once per column), rows split over the threads.
    class BlockMass
    {
    public:
      explicit BlockMass(const dealii::SparseMatrix<double> &M)
        : n(M.m())
      {
        row_start.reserve(n + 1);
        column.reserve(M.n_nonzero_elements());
        value.reserve(M.n_nonzero_elements());
        row_start.push_back(0);
        for (std::size_t row = 0; row < n; ++row)
          {
            for (auto it = M.begin(row); it != M.end(row); ++it)
              if (it->value() != 0.)
                {
                  column.push_back(it->column());
                  value.push_back(it->value());
                }
            row_start.push_back(column.size());
          }
      }

      std::size_t rows() const { return n; }

      // dst = M src for count columns of length n (column-major; dst must not alias src), four
      // at a time: a fixed width lets the compiler keep the four sums in registers (a loop over a
      // run-time width does not vectorize).
      void multiply(const double *src, double *dst, const int count) const
      {
        dealii::parallel::apply_to_subranges(
          std::size_t(0), n,
          [&](const std::size_t begin, const std::size_t end) {
            int first = 0;
            for (; first + 4 <= count; first += 4)
              multiply_rows<4>(src, dst, first, begin, end);
            for (; first < count; ++first)
              multiply_rows<1>(src, dst, first, begin, end);
          },
          4096);
      }

    private:
      // Rows begin to end of M times the columns first to first + width.
      template <int width>
      void multiply_rows(const double *src, double *dst, const int first, const std::size_t begin,
                         const std::size_t end) const
      {
        const double *columns[width];
        for (int c = 0; c < width; ++c)
          columns[c] = src + std::size_t(first + c) * n;
        for (std::size_t row = begin; row < end; ++row)
          {
            double sum[width] = {};
            for (std::size_t k = row_start[row]; k < row_start[row + 1]; ++k)
              for (int c = 0; c < width; ++c)
                sum[c] += value[k] * columns[c][column[k]];
            for (int c = 0; c < width; ++c)
              dst[std::size_t(first + c) * n + row] = sum[c];
          }
      }

      const std::size_t         n;
      std::vector<std::size_t>  row_start;
      std::vector<unsigned int> column;
      std::vector<double>       value;
    };

    // The serial problem: M's products on deal.II's threads, the solves by the factorization.
    class SerialBlockOperators : public BlockEigenOperators
    {
    public:
      SerialBlockOperators(const dealii::SparseMatrix<double> &M, Factorization &inverse)
        : M(M)
        , inverse(inverse)
      {}
      std::size_t  local_rows() const override { return M.rows(); }
      std::size_t  global_rows() const override { return M.rows(); }
      void         multiply_by_mass(const double *src, double *dst, const int count) override { M.multiply(src, dst, count); }
      void         solve(double *columns, const int count) override { inverse.solve_block(columns, count); }
      void         sum_over_processes(double *, std::size_t) const override {}
      unsigned int process() const override { return 0; }

    private:
      const BlockMass M;
      Factorization  &inverse;
    };

    class BlockKrylov
    {
    public:
      BlockKrylov(BlockEigenOperators &operators, unsigned int n_modes, unsigned int block_size, double tolerance,
                  double memory_limit_bytes, bool verbose, const CutOffStop &stop)
        : stop(stop)
        , operators(operators)
        , n(operators.local_rows())
        , nev(n_modes)
        , block(block_size)
        , tolerance(tolerance)
        , verbose(verbose)
      {
        // Three times the wanted count, whole blocks: with blocks of 4 this converged 50 modes in one
        // cycle (160 solved vectors, ARPACK: 141 single solves) on the FACTS plate.
        const std::size_t n_global = operators.global_rows();
        capacity = int(std::min<std::size_t>(n_global - 1, block * ((3 * nev + block - 1) / block + 1)));
        AssertThrow(capacity > nev + block, ExcMessage("Too few unknowns (" + std::to_string(n_global) + ") for " +
                                                       std::to_string(nev) + " modes."));
        store_mass_images = mass_images_fit(memory_limit_bytes);
        V.assign(std::size_t(n) * capacity, 0.);
        if (store_mass_images)
          MV.assign(std::size_t(n) * capacity, 0.);
        W.assign(std::size_t(n) * capacity, 0.);
        newest_MX.assign(std::size_t(n) * block, 0.);
      }

      EigenSolution solve(const double shift)
      {
        this->shift = shift;
        // The GEMMs on the basis run on every BLAS thread (they are bound by reading the basis, which
        // two threads read faster than one); the solves set their own.
        dealii::Timer     timer;
        std::vector<double> seed(std::size_t(n) * block);
        int                 size = start_from_random_block(seed);

        EigenSolution solution;
        std::vector<double> theta, Z;
        unsigned int cycle = 0;
        bool         trust_estimates = true;
        while (true)
          {
            // Grow the basis: the images of the newest block, orthogonalized, are the next block.
            // Before the first restart the basis is a block Krylov space, whose Ritz residuals cost
            // nothing (see estimate_converged): growth stops as soon as they say every wanted mode
            // has converged, before the next block is solved. The true residuals below decide.
            int pending = 0;
            while (size + block <= capacity)
              {
                const int newest = size - block;
                std::copy(W.begin() + std::size_t(newest) * n, W.begin() + std::size_t(size) * n, seed.begin());
                const bool krylov = cycle == 0;
                const int  added  = orthogonalize_block(seed.data(), block, size, krylov);
                if (added == 0)
                  break;
                if (krylov && trust_estimates && size >= block + int(stop.minimum) && estimate_converged(size, added))
                  {
                    pending = added;
                    break;
                  }
                solve_new_block(size, added);
                size += added;
                say_progress(size, timer.wall_time());
              }
            rayleigh_ritz(size, theta, Z);
            const int converged = count_converged(size, theta, Z);
            wanted              = wanted_count(theta);
            if (verbose)
              std::cout << "[eigensolve]   cycle " << cycle + 1 << ": basis " << size << ", " << converged << " of "
                        << wanted << " converged, " << solved << " vectors solved, " << timer.wall_time() << " s"
                        << std::endl;
            if (converged >= wanted)
              break;
            if (pending > 0)
              {
                // The estimates were optimistic (rounding): go on growing this basis.
                trust_estimates = false;
                solve_new_block(size, pending);
                size += pending;
                continue;
              }
            AssertThrow(++cycle < 50, ExcMessage(not_converged_message(converged, shift, theta)));
            size = restart(size, theta, Z);
          }

        solution.n_operator_applications = solved;
        // The Ritz vectors V Z of the last convergence check are the eigenvectors.
        orient_ritz_vectors();
        for (int i = 0; i < wanted; ++i)
          {
            solution.eigenvalues.push_back(shift + 1. / theta[i]);
            dealii::Vector<double> phi(n);
            std::copy(&ritz_vectors[std::size_t(i) * n], &ritz_vectors[std::size_t(i + 1) * n], phi.begin());
            solution.eigenvectors.push_back(std::move(phi));
          }
        solution.eigensolve_iteration_seconds            = timer.wall_time();
        solution.mass_product_seconds      = mass_seconds;
        solution.orthogonalization_seconds = orthogonalization_seconds;
        solution.mass_images_stored        = store_mass_images;
        return solution;
      }

    private:
      // The basis' first block: OP applied to a random block, which lies in the range of OP (zero on
      // clamped rows); 'seed' holds a block. The random block's first column also fixes the modes'
      // signs (orientation). Returns the basis' size.
      int start_from_random_block(std::vector<double> &seed)
      {
        std::mt19937_64 random(20261122 + operators.process());
        std::uniform_real_distribution<double> uniform(-1., 1.);
        for (double &x : seed)
          x = uniform(random);
        orientation.assign(seed.begin(), seed.begin() + n);
        std::vector<double> Mseed(seed.size());
        multiply_by_mass(seed.data(), Mseed.data(), block);
        solve_images(Mseed.data(), seed.data(), block);
        return append_block(seed.data(), block, 0);
      }

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

      // An eigenvector's sign is arbitrary, and the one the Rayleigh-Ritz step gives can flip with
      // round-off (MUMPS's solves under MPI are not bit-reproducible between runs): each Ritz vector
      // is turned to have a positive product with the random start column, which is the same in
      // every run on the same rows, so that two runs of one space export the same modes.
      void orient_ritz_vectors()
      {
        std::vector<double> products(n_ritz_vectors, 0.);
        for (int i = 0; i < n_ritz_vectors; ++i)
          for (int r = 0; r < n; ++r)
            products[i] += ritz_vectors[std::size_t(i) * n + r] * orientation[r];
        operators.sum_over_processes(products.data(), n_ritz_vectors);
        for (int i = 0; i < n_ritz_vectors; ++i)
          if (products[i] < 0.)
            for (int r = 0; r < n; ++r)
              ritz_vectors[std::size_t(i) * n + r] = -ritz_vectors[std::size_t(i) * n + r];
      }

      // dst = (K - sigma M)^-1 Msrc for count columns, Msrc = M src already computed.
      void solve_images(const double *Msrc, double *dst, const int count)
      {
        std::copy(Msrc, Msrc + std::size_t(n) * count, dst);
        operators.solve(dst, count);
        solved += count;
      }

      // W = OP V for the count basis columns from 'first' on, the newest ones (their M V is newest_MX).
      void solve_new_block(const int first, const int count)
      {
        solve_images(newest_MX.data(), &W[std::size_t(first) * n], count);
      }

      // The basis keeps M V beside V and W (Gram-Schmidt then reads it instead of multiplying by
      // M) when the three fit the limit; else M V is recomputed where needed (two more M products
      // per block, M W once per cycle): at 2.15 M DoFs on one process V, M V and W take 8 GB beside
      // the factor's in-core data. The same choice on every process.
      bool mass_images_fit(const double limit_bytes) const
      {
        const double bases_bytes     = 3. * 8. * double(n) * capacity;
        double       short_of_memory = bases_bytes > limit_bytes ? 1. : 0.;
        operators.sum_over_processes(&short_of_memory, 1);
        if (verbose && short_of_memory > 0.)
          std::cout << "[eigensolve]   M V recomputed, not stored: V, M V and OP V would take " << bases_bytes / 1e9
                    << " GB on this process, over the limit of " << limit_bytes / 1e9 << " GB" << std::endl;
        return short_of_memory == 0.;
      }

      // C = (M V)^T X for the first size basis columns (scratch: n x count).
      void mass_products_with_basis(const int size, const double *X, const int count, double *C,
                                    std::vector<double> &scratch)
      {
        if (store_mass_images)
          gemm('T', 'N', size, count, n, 1., MV.data(), n, X, n, 0., C, size);
        else
          {
            scratch.resize(std::size_t(n) * count);
            multiply_by_mass(X, scratch.data(), count);
            gemm('T', 'N', size, count, n, 1., V.data(), n, scratch.data(), n, 0., C, size);
          }
        operators.sum_over_processes(C, std::size_t(size) * count);
      }

      // A line every 30 s while the basis grows: a block solve takes tens of seconds with the
      // factor on disk at 10^6 DoFs.
      void say_progress(const int size, const double seconds)
      {
        if (!verbose || seconds < last_progress_line + 30.)
          return;
        last_progress_line = seconds;
        std::cout << "[eigensolve]   basis " << size << " of " << capacity << ", " << solved << " vectors solved, "
                  << seconds << " s" << std::endl;
      }

      void multiply_by_mass(const double *src, double *dst, const int count)
      {
        dealii::Timer timer;
        operators.multiply_by_mass(src, dst, count);
        mass_seconds += timer.wall_time();
      }

      // M-orthogonalizes X (n x count) against the first 'size' basis vectors and within itself,
      // appends it to V (with M V and W = OP V) and returns how many columns were added (0 when the
      // block collapsed: the Krylov space is exhausted).
      int append_block(double *X, const int count, const int size)
      {
        const int added = orthogonalize_block(X, count, size, false);
        if (added > 0)
          solve_new_block(size, added);
        return added;
      }

      // append_block without the solve (W of the new columns is left unset). With 'record', X is
      // W of the newest block (columns size - count to size) and its coefficients are kept in
      // 'arnoldi': W_newest = V C + X_new R, C from both Gram-Schmidt passes, R from both Cholesky QRs.
      int orthogonalize_block(double *X, const int count, const int size, const bool record)
      {
        dealii::Timer       timer;
        double              mass_before = mass_seconds;
        std::vector<double> C(std::size_t(std::max(size, 1)) * count), C_sum(C.size(), 0.), G(count * count),
          R(count * count, 0.);
        std::vector<double> &MX = newest_MX;
        MX.resize(std::size_t(n) * count);
        for (int i = 0; i < count; ++i)
          R[i + i * count] = 1.;
        // Two passes of classical Gram-Schmidt against the basis (each reads M V and V once), then
        // M X once (a block product) and two passes of Cholesky QR in the M inner product within
        // the block (X^T M X = R^T R, X <- X R^-1, M X <- M X R^-1: only the block is touched).
        for (int pass = 0; pass < 2 && size > 0; ++pass)
          {
            mass_products_with_basis(size, X, count, C.data(), MX);
            gemm('N', 'N', n, count, size, -1., V.data(), n, C.data(), size, 1., X, n);
            for (std::size_t i = 0; i < C.size(); ++i)
              C_sum[i] += C[i];
          }
        multiply_by_mass(X, MX.data(), count);
        for (int pass = 0; pass < 2; ++pass)
          {
            gemm('T', 'N', count, count, n, 1., X, n, MX.data(), n, 0., G.data(), count);
            operators.sum_over_processes(G.data(), G.size());
            int info = 0;
            dpotrf_("U", &count, G.data(), &count, &info);
            if (info != 0)
              {
                orthogonalization_seconds += timer.wall_time() - (mass_seconds - mass_before);
                return 0;
              }
            const double one = 1.;
            dtrsm_("R", "U", "N", "N", &n, &count, &one, G.data(), &count, X, &n);
            dtrsm_("R", "U", "N", "N", &n, &count, &one, G.data(), &count, MX.data(), &n);
            dtrmm_("L", "U", "N", "N", &count, &count, &one, G.data(), &count, R.data(), &count); // R <- G R
          }
        std::copy(X, X + std::size_t(n) * count, V.begin() + std::size_t(size) * n);
        if (store_mass_images)
          std::copy(MX.begin(), MX.end(), MV.begin() + std::size_t(size) * n);
        if (record)
          record_arnoldi_column(size, count, C_sum, R);
        orthogonalization_seconds += timer.wall_time() - (mass_seconds - mass_before);
        return count;
      }

      void record_arnoldi_column(const int size, const int count, const std::vector<double> &C, const std::vector<double> &R)
      {
        if (arnoldi.empty())
          arnoldi.assign(std::size_t(capacity) * capacity, 0.);
        for (int j = 0; j < count; ++j)
          {
            double *column = &arnoldi[std::size_t(size - count + j) * capacity];
            std::copy(&C[std::size_t(j) * size], &C[std::size_t(j + 1) * size], column);
            std::copy(&R[std::size_t(j) * count], &R[std::size_t(j + 1) * count], column + size);
          }
      }

      // The count the iteration converges: n_modes, or fewer once the cut-off decides it (theta:
      // the Ritz values, largest first, i.e. the eigenvalues shift + 1 / theta ascending).
      int wanted_count(const std::vector<double> &theta) const
      {
        std::vector<double> lowest;
        for (std::size_t i = 0; i < theta.size() && int(i) < nev; ++i)
          lowest.push_back(shift + 1. / theta[i]);
        return int(stop.decided_count(lowest, nev));
      }

      // Whether the wanted Ritz pairs of the first 'size' columns have converged, from the block
      // Krylov relation W = V H + X_new R E^T (E: the last block): the residual of the Ritz pair
      // (theta, V z) is X_new R z_last, whose M norm is |R z_last| (X_new is M-orthonormal). Needs
      // only the recorded coefficients: no product with the n-long bases.
      bool estimate_converged(const int size, const int count)
      {
        std::vector<double> H(std::size_t(size) * size), ascending(size);
        for (int j = 0; j < size; ++j)
          for (int i = 0; i < size; ++i)
            H[i + std::size_t(j) * size] =
              0.5 * (arnoldi[i + std::size_t(j) * capacity] + arnoldi[j + std::size_t(i) * capacity]);
        symmetric_eigen(size, H, ascending);
        int converged = 0;
        for (; converged < nev; ++converged)
          {
            const double *z = &H[std::size_t(size - 1 - converged) * size + (size - count)];
            double        norm2 = 0.;
            for (int i = 0; i < count; ++i)
              {
                double r = 0.;
                for (int k = i; k < count; ++k)
                  r += arnoldi[size + i + std::size_t(size - count + k) * capacity] * z[k];
                norm2 += r * r;
              }
            if (std::sqrt(norm2) > tolerance * std::abs(ascending[size - 1 - converged]))
              break;
          }
        return converged >= wanted_count(std::vector<double>(ascending.rbegin(), ascending.rend()));
      }

      // The eigenpairs of a symmetric size x size matrix A, in place: eigenvectors in A, eigenvalues ascending.
      static void symmetric_eigen(int size, std::vector<double> &A, std::vector<double> &ascending)
      {
        int    lwork = -1, info = 0;
        double query = 0.;
        dsyev_("V", "U", &size, A.data(), &size, ascending.data(), &query, &lwork, &info);
        lwork = int(query);
        std::vector<double> work(lwork);
        dsyev_("V", "U", &size, A.data(), &size, ascending.data(), work.data(), &lwork, &info);
        AssertThrow(info == 0, ExcMessage("LAPACK's dsyev failed in the Rayleigh-Ritz step."));
      }

      // H = (M V)^T W, symmetrized; its eigenpairs, largest theta first. Without M V stored:
      // V^T (M W), M W 16 columns at a time (each pass reads V once).
      void rayleigh_ritz(const int size, std::vector<double> &theta, std::vector<double> &Z)
      {
        Z.assign(std::size_t(size) * size, 0.);
        std::vector<double> scratch;
        const int           chunk = store_mass_images ? size : columns_per_mass_pass;
        for (int first = 0; first < size; first += chunk)
          {
            const int count = std::min(chunk, size - first);
            mass_products_with_basis(size, &W[std::size_t(first) * n], count, &Z[std::size_t(first) * size], scratch);
          }
        for (int i = 0; i < size; ++i)
          for (int j = 0; j < i; ++j)
            Z[i + std::size_t(j) * size] = Z[j + std::size_t(i) * size] =
              0.5 * (Z[i + std::size_t(j) * size] + Z[j + std::size_t(i) * size]);
        std::vector<double> ascending(size);
        symmetric_eigen(size, Z, ascending);
        // Reverse: largest theta (eigenvalue closest to the shift) first.
        theta.assign(ascending.rbegin(), ascending.rend());
        std::vector<double> reversed(Z.size());
        for (int i = 0; i < size; ++i)
          std::copy(Z.begin() + std::size_t(size - 1 - i) * size, Z.begin() + std::size_t(size - i) * size,
                    reversed.begin() + std::size_t(i) * size);
        Z.swap(reversed);
      }

      // Residuals r_i = W z_i - theta_i V z_i of the OP eigenproblem, in the M norm, relative to
      // theta_i; keeps the Ritz vectors V z_i in ritz_vectors.
      std::vector<double> residual_norms(const int size, const std::vector<double> &theta, const std::vector<double> &Z,
                                         const int count, std::vector<double> &R)
      {
        R.assign(std::size_t(n) * count, 0.);
        gemm('N', 'N', n, count, size, 1., W.data(), n, Z.data(), size, 0., R.data(), n);
        std::vector<double> &VZ = ritz_vectors;
        VZ.resize(std::size_t(n) * count);
        gemm('N', 'N', n, count, size, 1., V.data(), n, Z.data(), size, 0., VZ.data(), n);
        for (int c = 0; c < count; ++c)
          for (int i = 0; i < n; ++i)
            R[std::size_t(c) * n + i] -= theta[c] * VZ[std::size_t(c) * n + i];
        // M R a few columns at a time: at 10^6 rows a whole n x count block is most of a GB.
        const int           chunk = columns_per_mass_pass;
        std::vector<double> MR(std::size_t(n) * std::min(chunk, count)), norms(count, 0.);
        for (int first = 0; first < count; first += chunk)
          {
            const int columns = std::min(chunk, count - first);
            multiply_by_mass(&R[std::size_t(first) * n], MR.data(), columns);
            for (int c = 0; c < columns; ++c)
              for (int i = 0; i < n; ++i)
                norms[first + c] += R[std::size_t(first + c) * n + i] * MR[std::size_t(c) * n + i];
          }
        operators.sum_over_processes(norms.data(), count);
        for (int c = 0; c < count; ++c)
          norms[c] = std::sqrt(std::max(norms[c], 0.)) / std::abs(theta[c]);
        return norms;
      }

      int count_converged(const int size, const std::vector<double> &theta, const std::vector<double> &Z)
      {
        n_ritz_vectors   = std::min(nev, size); // fewer while the basis is smaller (a stop at the cut-off)
        const auto norms = residual_norms(size, theta, Z, n_ritz_vectors, residuals);
        int        converged = 0;
        while (converged < n_ritz_vectors && norms[converged] <= tolerance)
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
            if (basis->empty()) // M V, when it is recomputed instead of stored
              continue;
            gemm('N', 'N', n, keep, size, 1., basis->data(), n, Z.data(), size, 0., scratch.data(), n);
            std::copy(scratch.begin(), scratch.end(), basis->begin());
          }
        (void)theta;
        const int seeds = std::min(block, n_ritz_vectors - first_unconverged);
        std::vector<double> seed(residuals.begin() + std::size_t(first_unconverged) * n,
                                 residuals.begin() + std::size_t(first_unconverged + seeds) * n);
        return keep + append_block(seed.data(), seeds, keep);
      }

      const CutOffStop                    stop;
      double                              shift  = 0.;
      BlockEigenOperators                &operators;
      const int                           n, nev, block; // n: this process's rows
      int                                 wanted = 0;    // of the nev, those the cut-off needs (wanted_count)
      int                                 n_ritz_vectors = 0; // columns of ritz_vectors and residuals
      const double                        tolerance;
      const bool                          verbose;
      int                                 capacity = 0;
      unsigned int                        solved   = 0;
      int                                 first_unconverged = 0;
      bool                                store_mass_images = true; // M V kept (mass_images_fit)
      // Products with M whose results are not kept (V^T M W without M V, the residuals' M R) go
      // this many columns at a time: the scratch stays small and each pass over V reads it once.
      static constexpr int                columns_per_mass_pass = 16;
      std::vector<double>                 V, MV, W, residuals;
      std::vector<double>                 newest_MX; // M X of the block appended last: its solve's right-hand side
      double                              last_progress_line = 0.;
      std::vector<double>                 ritz_vectors; // V Z of the wanted pairs, from residual_norms
      std::vector<double>                 orientation;  // the random start's first column (orient_ritz_vectors)
      std::vector<double>                 arnoldi; // capacity x capacity, first cycle only (orthogonalize_block)
      double                              mass_seconds = 0., orthogonalization_seconds = 0.;
    };
  } // namespace

  std::string block_krylov_method(const unsigned int block_size, const EigenSolution &solution)
  {
    return "block Krylov (shift-invert, blocks of " + std::to_string(block_size) +
           (solution.mass_images_stored ? "" : ", M V recomputed") + ")";
  }

  EigenSolution solve_block_shift_invert(const dealii::SparseMatrix<double> &M,
                                         Factorization                      &shifted_inverse,
                                         const double                        shift,
                                         const unsigned int                  n_modes,
                                         const unsigned int                  block_size,
                                         const double                        tolerance,
                                         const double                        memory_limit_bytes,
                                         const bool                          verbose,
                                         const CutOffStop                   &stop)
  {
    SerialBlockOperators operators(M, shifted_inverse);
    return solve_block_shift_invert(operators, shift, n_modes, block_size, tolerance, memory_limit_bytes, verbose,
                                    stop);
  }

  EigenSolution solve_block_shift_invert(BlockEigenOperators &operators,
                                         const double         shift,
                                         const unsigned int   n_modes,
                                         const unsigned int   block_size,
                                         const double         tolerance,
                                         const double         memory_limit_bytes,
                                         const bool           verbose,
                                         const CutOffStop    &stop)
  {
    BlockKrylov solver(operators, n_modes, block_size, tolerance, memory_limit_bytes, verbose, stop);
    return solver.solve(shift);
  }

  unsigned int CutOffStop::decided_count(const std::vector<double> &lowest, const unsigned int n_modes) const
  {
    for (std::size_t count = std::max(1u, minimum); count <= lowest.size() && count <= n_modes; ++count)
      if (lowest[count - 1] > cut_off_eigenvalue)
        return count;
    return n_modes;
  }

  unsigned int CutOffStop::next_batch(const std::vector<double> &found, const unsigned int n_modes) const
  {
    const unsigned int n_found = found.size();
    if (n_found >= n_modes || (n_found > 0 && decided_count(found, n_modes) <= n_found))
      return 0;
    if (std::isinf(cut_off_eigenvalue))
      return n_modes - n_found;
    // The floor and a margin, for a cut-off a little above the floor's modes: 15 for the default floor of 10.
    const unsigned int floor = std::max(1u, minimum);
    return std::min(n_modes - n_found, n_found > 0 ? n_found : floor + std::max(4u, floor / 2));
  }
} // namespace modal_haptics
