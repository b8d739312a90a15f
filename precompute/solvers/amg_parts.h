// The AMG path's parts (amg_eigensolver.h), shared by its files only: the Epetra operators it is
// built from (products on every core, the deflation by the modes, the AMG on the free DoFs, the
// two-level preconditioner of a higher-order space, M watched for LOBPCG) and
// AmgShiftedInverse::Impl, which holds them: it is set up and solves static
// loads (amg_shifted_inverse.cc); amg_lobpcg.cc runs LOBPCG; vertex_space_transfer.cc builds the vertex space.
#pragma once

#include "solvers/amg_eigensolver.h"

#include "solvers/blas_lapack.h"
#include "scene/rigid_body_motion.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/timer.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <AnasaziBasicEigenproblem.hpp>
#include <AnasaziEpetraAdapter.hpp>
#include <AnasaziBasicSort.hpp>
#include <AnasaziLOBPCG.hpp>
#include <AnasaziSVQBOrthoManager.hpp>
#include <AnasaziStatusTestCombo.hpp>
#include <AnasaziStatusTestMaxIters.hpp>
#include <AnasaziStatusTestResNorm.hpp>
#include <AnasaziStatusTestWithOrdering.hpp>
#include <BelosBlockCGSolMgr.hpp>
#include <BelosEpetraAdapter.hpp>
#include <BelosLinearProblem.hpp>
#include <EpetraExt_MatrixMatrix.h>
#include <Epetra_CrsMatrix.h>
#include <Epetra_LocalMap.h>
#include <Epetra_MultiVector.h>
#include <Epetra_Operator.h>
#include <Epetra_Vector.h>
#include <Ifpack_Chebyshev.h>
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>
#include <ml_MultiLevelPreconditioner.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>

namespace modal_haptics
{
  namespace amg
  {
    // The Epetra_Operator interface around one operation: the maps and communicator are those of
    // another operator ('shape'); the operation it does not define (Apply for a preconditioner,
    // ApplyInverse for a product), the transpose and the norm (neither Anasazi nor Belos asks)
    // are refused.
    class OperatorShapedLike : public Epetra_Operator
    {
    public:
      OperatorShapedLike(const Epetra_Operator &shape, const char *label)
        : shape(shape), label(label)
      {}

      int Apply(const Epetra_MultiVector &, Epetra_MultiVector &) const override { return -1; }
      int ApplyInverse(const Epetra_MultiVector &, Epetra_MultiVector &) const override { return -1; }
      int SetUseTranspose(bool) override { return -1; }
      bool UseTranspose() const override { return false; }
      double NormInf() const override { return 0.; }
      bool HasNormInf() const override { return false; }
      const char *Label() const override { return label; }
      const Epetra_Comm &Comm() const override { return shape.Comm(); }
      const Epetra_Map &OperatorDomainMap() const override { return shape.OperatorDomainMap(); }
      const Epetra_Map &OperatorRangeMap() const override { return shape.OperatorRangeMap(); }

    private:
      const Epetra_Operator &shape;
      const char            *label;
    };

    // A sparse matrix applied to blocks of columns on every core. Trilinos' Epetra has no threads
    // here (Debian builds it without OpenMP): its product (epetra_scrsmm5, five columns per pass
    // over the matrix) took half of this path's time on one process, on one of the cores.
    // Under MPI, where each process has its core and the ghost entries must be imported, Epetra's
    // own product is used.
    class ThreadedMatrix : public OperatorShapedLike
    {
    public:
      explicit ThreadedMatrix(const Epetra_CrsMatrix &matrix)
        : OperatorShapedLike(matrix, "sparse matrix on every core"), matrix(matrix)
      {
        own_rows = matrix.Comm().NumProc() == 1 && matrix.StorageOptimized() &&
                   matrix.RowMap().SameAs(matrix.ColMap()) &&
                   matrix.ExtractCrsDataPointers(row_start, column, value) == 0;
      }

      int Apply(const Epetra_MultiVector &X, Epetra_MultiVector &Y) const override
      {
        if (!own_rows)
          return matrix.Apply(X, Y);
        const int n_rows = matrix.NumMyRows();
        interleaved.resize(std::size_t(n_rows) * width);
        for (int first = 0; first < X.NumVectors(); first += width)
          {
            const int count = std::min(width, X.NumVectors() - first);
            dealii::parallel::apply_to_subranges(
              0, n_rows, [&](const int begin, const int end) { interleave(X, first, count, begin, end); }, 4096);
            dealii::parallel::apply_to_subranges(
              0, n_rows, [&](const int begin, const int end) { multiply_rows(Y, first, count, begin, end); }, 2048);
          }
        return 0;
      }

    private:
      // Columns first to first + count of X, row by row (a row's entries side by side, the rest of
      // the width zero): each entry of the matrix then multiplies one contiguous run of X.
      void interleave(const Epetra_MultiVector &X, const int first, const int count, const int begin,
                      const int end) const
      {
        for (int row = begin; row < end; ++row)
          {
            double *out = &interleaved[std::size_t(row) * width];
            for (int c = 0; c < width; ++c)
              out[c] = c < count ? X[first + c][row] : 0.;
          }
      }

      // Rows begin to end of Y's columns first to first + count from the interleaved columns: a
      // fixed width keeps the sums in registers, and each pass over the matrix serves all of them.
      void multiply_rows(Epetra_MultiVector &Y, const int first, const int count, const int begin, const int end) const
      {
        for (int row = begin; row < end; ++row)
          {
            double sum[width] = {};
            for (int k = row_start[row]; k < row_start[row + 1]; ++k)
              {
                const double  a = value[k];
                const double *x = &interleaved[std::size_t(column[k]) * width];
                for (int c = 0; c < width; ++c)
                  sum[c] += a * x[c];
              }
            for (int c = 0; c < count; ++c)
              Y[first + c][row] = sum[c];
          }
      }

      static constexpr int width = 8; // columns per pass over the matrix
      const Epetra_CrsMatrix &matrix;
      bool                    own_rows  = false; // one process, columns numbered as rows: our product
      int                    *row_start = nullptr, *column = nullptr;
      double                 *value     = nullptr;
      mutable std::vector<double> interleaved; // width columns of X, row by row
    };
    // The span of the computed modes Z, deflated from the static solves by the balancing
    // preconditioner (BNN; Tang, Nabben, Vuik and Erlangga, J. Sci. Comput. 39, 2009):
    //   B_deflated = P^T B^-1 P + Q,  Q = Z E^-1 Z^T,  E = Z^T A Z,  P = I - A Q,
    // exact on span Z (its part of the solution, Q r) and the AMG's B^-1 on the A-orthogonal
    // rest, where the lowest (and, for the AMG on a thin part, the worst approximated) modes no
    // longer slow CG. It is symmetric positive definite, so CG's theory and its rounding behaviour
    // hold; the cheaper one-sided A-DEF2 (P^T B^-1 alone, from x0 = Q b) stagnated above 1e-12 on
    // the cantilever of test_lobpcg_amg. E is formed from Z, not taken as the eigenvalues: the modes
    // are converged to a tolerance, not exact, and the projections stay consistent for any basis.
    class Deflation
    {
    public:
      Deflation(const Epetra_Operator &A, Epetra_MultiVector modes)
        : Z(std::move(modes))
        , AZ(Z.Map(), Z.NumVectors())
        , k(Z.NumVectors())
        , coefficient_map(k, 0, Z.Comm())
        , E(std::size_t(k) * k)
      {
        A.Apply(Z, AZ);
        Epetra_MultiVector ZtAZ(coefficient_map, k);
        ZtAZ.Multiply('T', 'N', 1., Z, AZ, 0.); // summed over the processes
        for (int j = 0; j < k; ++j)
          for (int i = 0; i < k; ++i)
            E[i + std::size_t(j) * k] = 0.5 * (ZtAZ[j][i] + ZtAZ[i][j]);
        int info = 0;
        dpotrf_("L", &k, E.data(), &k, &info);
        AssertThrow(info == 0, dealii::ExcMessage("The modes used to deflate the static solves are not independent (Z^T A Z "
                                          "not positive definite at its column " + std::to_string(info) + ")."));
      }

      // Y = (P^T B^-1 P + Q) R, B^-1 applied by 'preconditioner'.
      int apply(const std::function<int(const Epetra_MultiVector &, Epetra_MultiVector &)> &preconditioner,
                const Epetra_MultiVector &R, Epetra_MultiVector &Y) const
      {
        Epetra_MultiVector in_span(coefficient_map, R.NumVectors()), off_span(coefficient_map, R.NumVectors());
        coefficients(Z, R, in_span);                 // E^-1 Z^T R: Q R = Z in_span
        Epetra_MultiVector PR(R);
        PR.Multiply('N', 'N', -1., AZ, in_span, 1.); // P R = R - A Z E^-1 Z^T R
        const int status = preconditioner(PR, Y);
        coefficients(AZ, Y, off_span);                // P^T Y = Y - Z E^-1 (A Z)^T Y
        off_span.Update(-1., in_span, 1.);           // ... + Z in_span
        Y.Multiply('N', 'N', -1., Z, off_span, 1.);
        return status;
      }

      int size() const { return k; }

    private:
      // C = E^-1 Y^T X (k x columns, on every process).
      void coefficients(const Epetra_MultiVector &Y, const Epetra_MultiVector &X, Epetra_MultiVector &C) const
      {
        C.Multiply('T', 'N', 1., Y, X, 0.); // summed over the processes
        const int n_rhs = C.NumVectors(), ld = C.Stride();
        int       info  = 0;
        dpotrs_("L", &k, &n_rhs, E.data(), &k, C.Values(), &ld, &info);
      }

      Epetra_MultiVector  Z, AZ;
      int                 k;
      Epetra_LocalMap     coefficient_map; // k rows on every process
      std::vector<double> E;               // Cholesky factor of Z^T A Z (lower, column-major)
    };

    // The AMG as an Epetra preconditioner (Anasazi and Belos call Apply; ML's V-cycle is its
    // ApplyInverse) on the free DoFs; the constrained DoFs, whose rows of A hold only their
    // diagonal, are kept out of the V-cycle's input and get either zero (LOBPCG: every field of the
    // constrained system is zero there, and M's zero rows would otherwise let its search directions
    // pick up directions of infinite eigenvalue) or their exact inverse (CG: with zero there it
    // could not reduce a load's residual on them and would stall).
    class ProjectedAmg : public OperatorShapedLike
    {
    public:
      // constrained_diagonal: A's diagonal on the constrained rows, or null for zero there;
      // deflation: when given, the AMG inside the deflated preconditioner (Deflation::apply).
      ProjectedAmg(const Epetra_Operator &amg, const std::vector<unsigned int> &constrained,
                   const std::vector<double> *constrained_diagonal, std::string what,
                   std::function<void(const std::string &)> progress, const Deflation *deflation = nullptr)
        : OperatorShapedLike(amg, "AMG (ML) on the free DoFs"), amg(amg), constrained(constrained),
          constrained_diagonal(constrained_diagonal), what(std::move(what)),
          progress(std::move(progress)), deflation(deflation)
      {}

      int Apply(const Epetra_MultiVector &X, Epetra_MultiVector &Y) const override
      {
        if (deflation == nullptr)
          return apply_amg(X, Y);
        return deflation->apply([this](const Epetra_MultiVector &R, Epetra_MultiVector &Z) { return apply_amg(R, Z); },
                                X, Y);
      }

      mutable unsigned long n_applications = 0; // columns

    private:
      int apply_amg(const Epetra_MultiVector &X, Epetra_MultiVector &Y) const
      {
        if (!free_part || free_part->NumVectors() != X.NumVectors())
          free_part = std::make_unique<Epetra_MultiVector>(X.Map(), X.NumVectors(), false);
        *free_part = X;
        for (int c = 0; c < X.NumVectors(); ++c)
          for (const unsigned int i : constrained)
            (*free_part)[c][i] = 0.;
        const int status = amg.ApplyInverse(*free_part, Y);
        for (int c = 0; c < Y.NumVectors(); ++c)
          for (std::size_t k = 0; k < constrained.size(); ++k)
            Y[c][constrained[k]] =
              constrained_diagonal != nullptr ? X[c][constrained[k]] / (*constrained_diagonal)[k] : 0.;
        n_applications += X.NumVectors();
        if (progress && since_progress.wall_time() > 30.)
          {
            progress(what + ": " + std::to_string(n_applications) + " preconditioner applications, " +
                     std::to_string(int(total.wall_time())) + " s");
            since_progress.restart();
          }
        return status;
      }

      const Epetra_Operator                          &amg;
      const std::vector<unsigned int>                &constrained;
      const std::vector<double>                      *constrained_diagonal;
      const std::string                               what;
      const std::function<void(const std::string &)>  progress; // a line every 30 s of long work, if set
      mutable std::unique_ptr<Epetra_MultiVector>     free_part;
      mutable dealii::Timer                           total, since_progress;
      const Deflation                                *deflation;
    };
    // The preconditioner of a higher-order space (p-multigrid with two levels): Chebyshev
    // smoothing on the space, the correction from its vertex (P1) space through the Galerkin
    // operator P^T A P, where smoothed aggregation works as on a linear space, and the same
    // smoothing again. Symmetric positive definite (the same polynomial before and after, a
    // Galerkin coarse level solved by a symmetric V-cycle), as CG and LOBPCG need. The smoother
    // takes the error components P1 cannot hold (the edge nodes' high frequencies); ML on the P2
    // nodes themselves, without that split, needed 88-98 LOBPCG iterations on the P2 FACTS plate
    // of 14,220 DoFs against 70 with this and 56 with the coarse level's 4 sweeps
    // (docs/performance.md). A is applied by 'product' (ThreadedMatrix).
    class VertexTwoLevel : public OperatorShapedLike
    {
    public:
      VertexTwoLevel(const Epetra_CrsMatrix &A, const Epetra_Operator &product, const Epetra_CrsMatrix &P,
                     Teuchos::ParameterList coarse_ml)
        : OperatorShapedLike(product, "P2 smoothing over the vertex space's AMG"), A(product), P(P),
          inverse_diagonal(A.RowMap()), smoother(&product)
      {
        {
          Epetra_CrsMatrix AP(Copy, A.RowMap(), 0);
          check(EpetraExt::MatrixMatrix::Multiply(A, false, P, false, AP), "A P");
          coarse_matrix = std::make_unique<Epetra_CrsMatrix>(Copy, P.DomainMap(), 0);
          check(EpetraExt::MatrixMatrix::Multiply(P, true, AP, false, *coarse_matrix), "P^T A P");
        }
        // The coarse level's own smoothing is a fourth-degree Chebyshev polynomial (ML's sweeps):
        // 56 LOBPCG iterations on that plate against 70 with two sweeps, at less time overall.
        coarse_ml.set("smoother: sweeps", 4);
        coarse.initialize(*coarse_matrix, coarse_ml);
        A.ExtractDiagonalCopy(inverse_diagonal);
        inverse_diagonal.Reciprocal(inverse_diagonal);
        set_up_smoother(A, product);
      }

      // The smoother's interval and where its upper end came from, for the run's description.
      std::string smoother_interval() const
      {
        std::ostringstream text;
        text << std::setprecision(3) << "Chebyshev degree 3 on [" << lambda_max() / 20. << ", " << lambda_max()
             << "] of D^-1 A: Lanczos estimate " << lanczos_estimate << ", Gershgorin bound " << gershgorin_bound;
        return text.str();
      }

      // X = B^-1 R: pre-smoothing from zero, coarse correction, post-smoothing.
      int ApplyInverse(const Epetra_MultiVector &R, Epetra_MultiVector &X) const override
      {
        size_buffers(R);
        smoother.ApplyInverse(R, X);
        residual(R, X, *fine_work);
        P.Multiply(true, *fine_work, *coarse_residual);
        coarse.trilinos_operator().ApplyInverse(*coarse_residual, *coarse_correction);
        P.Multiply(false, *coarse_correction, *fine_work);
        X.Update(1., *fine_work, 1.);
        residual(R, X, *fine_work);
        smoother.ApplyInverse(*fine_work, *smoothed);
        return X.Update(1., *smoothed, 1.);
      }

    private:
      static void check(const int status, const std::string &what)
      {
        AssertThrow(status == 0, dealii::ExcMessage("Forming " + what + " for the vertex-space AMG failed (EpetraExt status " +
                                            std::to_string(status) + ")."));
      }

      // Degree 3 over [lambda_max / 20, lambda_max] of D^-1 A. A Chebyshev polynomial grows fast
      // above its interval: eigenvalues of D^-1 A above a lambda_max that is too low are amplified
      // and the preconditioner turns indefinite. ML's estimate (10 power steps, times 1.1) was too
      // low at 2.15 M P2 DoFs (LOBPCG's lowest residual stalled at 40 times its Ritz value and its
      // basis broke down); the Gershgorin bound is safe but 2.4 times the true maximum on the 57k
      // P2 plate, which costs 30 % more iterations there. So lambda_max is the smaller of the
      // Gershgorin bound and a Lanczos upper estimate (1.21-1.23 times the maximum on that plate;
      // docs/performance.md). Degree 5 took 61 instead of 70 iterations on the 14k plate, but longer.
      void set_up_smoother(const Epetra_CrsMatrix &matrix, const Epetra_Operator &product)
      {
        gershgorin_bound = gershgorin_upper_bound(matrix);
        lanczos_estimate = lanczos_upper_estimate(product, 10);
        Teuchos::ParameterList chebyshev;
        chebyshev.set("chebyshev: degree", 3);
        chebyshev.set("chebyshev: max eigenvalue", lambda_max());
        chebyshev.set("chebyshev: ratio eigenvalue", 20.);
        chebyshev.set("chebyshev: zero starting solution", true);
        chebyshev.set("chebyshev: operator inv diagonal", &inverse_diagonal);
        check(smoother.SetParameters(chebyshev) + smoother.Initialize() + smoother.Compute(), "the Chebyshev smoother");
      }

      double lambda_max() const { return std::min(gershgorin_bound, lanczos_estimate); }

      // max over the rows of sum_j |a_ij| / a_ii: a guaranteed upper bound of lambda_max(D^-1 A).
      double gershgorin_upper_bound(const Epetra_CrsMatrix &matrix) const
      {
        double local_bound = 0.;
        for (int row = 0; row < matrix.NumMyRows(); ++row)
          {
            int     length;
            double *values;
            int    *columns;
            matrix.ExtractMyRowView(row, length, values, columns);
            double sum = 0.;
            for (int k = 0; k < length; ++k)
              sum += std::abs(values[k]);
            local_bound = std::max(local_bound, sum * inverse_diagonal[row]);
          }
        double bound = 0.;
        matrix.Comm().MaxAll(&local_bound, &bound, 1);
        return bound;
      }

      // An upper estimate of lambda_max(D^-1 A): 'steps' Lanczos steps on D^-1/2 A D^-1/2 from a
      // random start, the largest Ritz value plus the last off-diagonal beta (Zhou and Li's bound
      // for Chebyshev filters). The Ritz value approaches lambda_max from below much faster than
      // power steps do (0.95-0.97 of it after 10 steps on the 57k P2 plate, power steps 0.88), and beta,
      // about a quarter of the spectrum's width there, covers the rest with room to spare.
      double lanczos_upper_estimate(const Epetra_Operator &product, const unsigned int steps) const
      {
        const Epetra_BlockMap &map = inverse_diagonal.Map();
        Epetra_Vector          scale(inverse_diagonal), q(map), previous(map), scaled(map), Aq(map), w(map);
        for (int i = 0; i < scale.MyLength(); ++i)
          scale[i] = std::sqrt(scale[i]);
        q.Random();
        double norm = 0.;
        q.Norm2(&norm);
        q.Scale(1. / norm);
        std::vector<double> alpha, beta;
        for (unsigned int step = 0; step < steps; ++step)
          {
            scaled.Multiply(1., scale, q, 0.);
            product.Apply(scaled, Aq);
            w.Multiply(1., scale, Aq, 0.);
            double a = 0., b = 0.;
            q.Dot(w, &a);
            w.Update(-a, q, beta.empty() ? 0. : -beta.back(), previous, 1.);
            w.Norm2(&b);
            alpha.push_back(a), beta.push_back(b);
            if (b <= 1e-12 * std::abs(a)) // an invariant subspace: the Ritz values are eigenvalues
              break;
            previous = q;
            q.Update(1. / b, w, 0.);
          }
        const int           k = alpha.size();
        std::vector<double> T(std::size_t(k) * k, 0.), ritz(k), work(3 * k);
        for (int i = 0; i < k; ++i)
          {
            T[i + i * k] = alpha[i];
            if (i + 1 < k)
              T[i + 1 + i * k] = T[i + (i + 1) * k] = beta[i];
          }
        const int lwork = work.size();
        int       info  = 0;
        dsyev_("N", "U", &k, T.data(), &k, ritz.data(), work.data(), &lwork, &info);
        AssertThrow(info == 0, dealii::ExcMessage("LAPACK's dsyev failed on the Lanczos matrix of the P2 smoother (info " +
                                          std::to_string(info) + ")."));
        return ritz.back() + beta.back();
      }

      void residual(const Epetra_MultiVector &R, const Epetra_MultiVector &X, Epetra_MultiVector &out) const
      {
        A.Apply(X, out);
        out.Update(1., R, -1.);
      }

      void size_buffers(const Epetra_MultiVector &R) const
      {
        if (fine_work && fine_work->NumVectors() == R.NumVectors())
          return;
        fine_work         = std::make_unique<Epetra_MultiVector>(A.OperatorRangeMap(), R.NumVectors(), false);
        smoothed          = std::make_unique<Epetra_MultiVector>(A.OperatorRangeMap(), R.NumVectors(), false);
        coarse_residual   = std::make_unique<Epetra_MultiVector>(P.DomainMap(), R.NumVectors(), false);
        coarse_correction = std::make_unique<Epetra_MultiVector>(P.DomainMap(), R.NumVectors(), false);
      }

      const Epetra_Operator                      &A; // applied on every core
      const Epetra_CrsMatrix                     &P;
      std::unique_ptr<Epetra_CrsMatrix>           coarse_matrix;
      dealii::TrilinosWrappers::PreconditionAMG   coarse;
      Epetra_Vector                               inverse_diagonal;
      Ifpack_Chebyshev                            smoother;
      double gershgorin_bound = 0., lanczos_estimate = 0.; // of lambda_max(D^-1 A)
      mutable std::unique_ptr<Epetra_MultiVector> fine_work, smoothed, coarse_residual, coarse_correction;
    };
    // The mean of M's diagonal over the unconstrained rows (theirs are zero), over all processes.
    inline double mean_free_diagonal(const dealii::TrilinosWrappers::SparseMatrix &M)
    {
      const Epetra_CrsMatrix &matrix = M.trilinos_matrix();
      Epetra_Vector           diagonal(matrix.RowMap());
      matrix.ExtractDiagonalCopy(diagonal);
      double local[2] = {0., 0.}, global[2];
      for (int k = 0; k < diagonal.MyLength(); ++k)
        if (diagonal[k] != 0.)
          local[0] += diagonal[k], local[1] += 1.;
      matrix.Comm().SumAll(local, global, 2);
      return global[1] > 0. ? global[0] / global[1] : 1.;
    }
    // M for LOBPCG, watching that LOBPCG still iterates. An iteration applies the preconditioner
    // once and M to a few blocks, but Anasazi's SVQB orthonormalization bounds neither its passes
    // nor its restarts from random vectors, and once (P2, 2.15 M DoFs, np = 2, a block of 23, its
    // 62nd iteration; docs/performance.md) it kept applying M without another iteration. Past 200
    // blocks of M products since the last preconditioner application the run stops, saying so.
    class MassWatchingLobpcg : public OperatorShapedLike
    {
    public:
      MassWatchingLobpcg(const Epetra_Operator &M, const ProjectedAmg &preconditioner, const int block_size)
        : OperatorShapedLike(M, "M, watching LOBPCG"), M(M), preconditioner(preconditioner), limit(200ul * block_size)
      {}

      int Apply(const Epetra_MultiVector &X, Epetra_MultiVector &Y) const override
      {
        if (preconditioner.n_applications != applications_seen)
          applications_seen = preconditioner.n_applications, columns_since = 0;
        columns_since += X.NumVectors();
        AssertThrow(columns_since <= limit,
                    dealii::ExcMessage("LOBPCG stalled: Anasazi's orthonormalization applied M to " +
                               std::to_string(columns_since) + " vectors since LOBPCG's last iteration (after " +
                               std::to_string(applications_seen) + " preconditioner applications). Another "
                               "'Modes/LOBPCG modes per run' or a looser 'Modes/LOBPCG tolerance' changes the blocks "
                               "it orthonormalizes."));
        return M.Apply(X, Y);
      }

    private:
      const Epetra_Operator &M;
      const ProjectedAmg    &preconditioner;
      const unsigned long    limit; // columns
      mutable unsigned long  applications_seen = 0, columns_since = 0;
    };
    // Smoothed aggregation (ML) on a linear space of n_rows DoFs whose near-null space is the six
    // rigid-body motions (six columns, read by ML while it sets up: they must outlive that).
    inline Teuchos::ParameterList ml_parameters(std::vector<double> &near_null_space, const bool node_blocked,
                                         const std::size_t n_rows)
    {
      Teuchos::ParameterList ml;
      ML_Epetra::SetDefaults("SA", ml);
      ml.set("ML output", 0);
      ml.set("PDE equations", node_blocked ? 3 : 1);
      ml.set("null space: type", "pre-computed");
      ml.set("null space: dimension", 6);
      ml.set("null space: vectors", near_null_space.data());
      ml.set("aggregation: type", "Uncoupled");
      ml.set("smoother: type", "Chebyshev");
      ml.set("smoother: sweeps", 2);
      ml.set("coarse: type", "Amesos-KLU");
      // A coarse level of at most a tenth of the DoFs (and at most 1000): on a small part a coarse
      // level holding everything makes the AMG an exact solve, and LOBPCG, converging in a step or
      // two, breaks down on its linearly dependent search directions (seen at 1047 DoFs).
      ml.set("coarse: max size", int(std::clamp<std::size_t>(n_rows / 10, 60, 1000)));
      return ml;
    }
  } // namespace amg

  struct AmgShiftedInverse::Impl
  {
    double                                     shift = 0.;
    std::vector<unsigned int>                  constrained;          // local rows
    std::vector<double>                        constrained_diagonal; // A's, on the constrained rows
    dealii::TrilinosWrappers::SparseMatrix     own_A, own_M;         // the copies it holds, when it holds them
    const dealii::TrilinosWrappers::SparseMatrix *A = nullptr, *M = nullptr; // A = K - shift M
    std::unique_ptr<amg::ThreadedMatrix>            A_product, M_product; // A and M applied on every core
    std::vector<double>                        near_null_space; // six columns, read by ML while it sets up
    // The preconditioner: smoothed aggregation on the space itself for linear elements, else the
    // two levels over the vertex space (with that space's near-null space and interpolation).
    dealii::TrilinosWrappers::PreconditionAMG  amg;
    std::vector<double>                        vertex_near_null_space;
    std::shared_ptr<const dealii::TrilinosWrappers::SparseMatrix> prolongation;
    std::unique_ptr<amg::VertexTwoLevel>            vertex_two_level;
    const Epetra_Operator &amg_operator() const
    {
      return vertex_two_level ? static_cast<const Epetra_Operator &>(*vertex_two_level) : amg.trilinos_operator();
    }
    std::unique_ptr<amg::Deflation>                 deflation; // by the modes, once they are known
    std::function<void(const std::string &)>   progress;  // lowest_modes' lines, for the static solves too
    AmgSolverStatistics                        stats;
    unsigned long                              total_cg_iterations = 0;

    void set_up(double shift, const std::vector<unsigned int> &constrained, bool node_blocked,
                const VertexSpaceTransfer *vertex_space);
    struct LobpcgRun
    {
      int iterations, modes_found;
    };
    LobpcgRun lobpcg_run(Epetra_MultiVector &found, int first, int count, double tolerance,
                         const amg::ProjectedAmg &preconditioner, std::vector<double> &eigenvalues,
                         std::unique_ptr<Epetra_MultiVector>            &start,
                         const std::function<void(const std::string &)> &progress, const CutOffStop &stop) const;

    // A X = B by block CG (Trilinos Belos) from zero, preconditioned by the AMG and deflated by
    // the modes once they are known, every column to 1e-12 of its load. One block Krylov space for
    // all the columns: each iteration applies A and the V-cycle to the whole block at once.
    void block_conjugate_gradients(Epetra_MultiVector &X, const Epetra_MultiVector &B)
    {
      using MV = Epetra_MultiVector;
      using OP = Epetra_Operator;
      // A block's solve takes seconds on small parts, but over half an hour at 2 M P2 DoFs.
      const amg::ProjectedAmg preconditioner(amg_operator(), constrained, &constrained_diagonal,
                                        "block CG of " + std::to_string(X.NumVectors()) + " columns", progress,
                                        deflation.get());
      X.PutScalar(0.); // the first preconditioned residual holds the solution's part in span Z
      Belos::LinearProblem<double, MV, OP> problem(Teuchos::rcp(A_product.get(), false),
                                                   Teuchos::rcp(&X, false), Teuchos::rcp(&B, false));
      problem.setLeftPrec(Teuchos::rcp(&preconditioner, false));
      AssertThrow(problem.setProblem(), dealii::ExcMessage("Belos could not set up the static solves' linear problem."));
      auto parameters = Teuchos::rcp(new Teuchos::ParameterList);
      parameters->set("Block Size", X.NumVectors());
      parameters->set("Maximum Iterations", 20000);
      parameters->set("Convergence Tolerance", 1e-12);
      parameters->set("Implicit Residual Scaling", std::string("Norm of RHS"));
      Belos::BlockCGSolMgr<double, MV, OP> solver(Teuchos::rcp(&problem, false), parameters);
      const Belos::ReturnType converged = solver.solve();
      AssertThrow(converged == Belos::Converged,
                  dealii::ExcMessage("The AMG-preconditioned block CG of the static solves did not converge: relative "
                             "residual " + std::to_string(solver.achievedTol()) + " after " +
                             std::to_string(solver.getNumIters()) + " iterations."));
      const unsigned int iterations = solver.getNumIters();
      stats.n_cg_solves += X.NumVectors();
      total_cg_iterations += std::size_t(iterations) * X.NumVectors();
      stats.max_cg_iterations  = std::max(stats.max_cg_iterations, iterations);
      stats.mean_cg_iterations = double(total_cg_iterations) / stats.n_cg_solves;
    }

    void deflate(Epetra_MultiVector modes)
    {
      dealii::Timer timer;
      deflation = std::make_unique<amg::Deflation>(*A_product, std::move(modes));
      stats.deflation_modes   = deflation->size();
      stats.deflation_seconds = timer.wall_time();
    }
  };
} // namespace modal_haptics
