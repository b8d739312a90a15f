// LOBPCG + AMG (amg_eigensolver.h): Trilinos Anasazi's LOBPCG on (K - shift M, M), ML's
// smoothed aggregation with the rigid-body near-null space as its preconditioner, and Belos' block
// CG with the same preconditioner for the static solves.
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
  using dealii::ExcMessage;

  namespace
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
  } // namespace

  namespace
  {
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
        AssertThrow(info == 0, ExcMessage("The modes used to deflate the static solves are not independent (Z^T A Z "
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
  } // namespace

  namespace
  {
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
        AssertThrow(status == 0, ExcMessage("Forming " + what + " for the vertex-space AMG failed (EpetraExt status " +
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
        AssertThrow(info == 0, ExcMessage("LAPACK's dsyev failed on the Lanczos matrix of the P2 smoother (info " +
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
  } // namespace

  namespace
  {
    // The mean of M's diagonal over the unconstrained rows (theirs are zero), over all processes.
    double mean_free_diagonal(const dealii::TrilinosWrappers::SparseMatrix &M)
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
  } // namespace

  namespace
  {
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
                    ExcMessage("LOBPCG stalled: Anasazi's orthonormalization applied M to " +
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
  } // namespace

  namespace
  {
    // Smoothed aggregation (ML) on a linear space of n_rows DoFs whose near-null space is the six
    // rigid-body motions (six columns, read by ML while it sets up: they must outlive that).
    Teuchos::ParameterList ml_parameters(std::vector<double> &near_null_space, const bool node_blocked,
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
  } // namespace

  struct AmgShiftedInverse::Impl
  {
    double                                     shift = 0.;
    std::vector<unsigned int>                  constrained;          // local rows
    std::vector<double>                        constrained_diagonal; // A's, on the constrained rows
    dealii::TrilinosWrappers::SparseMatrix     own_A, own_M;         // the copies it holds, when it holds them
    const dealii::TrilinosWrappers::SparseMatrix *A = nullptr, *M = nullptr; // A = K - shift M
    std::unique_ptr<ThreadedMatrix>            A_product, M_product; // A and M applied on every core
    std::vector<double>                        near_null_space; // six columns, read by ML while it sets up
    // The preconditioner: smoothed aggregation on the space itself for linear elements, else the
    // two levels over the vertex space (with that space's near-null space and interpolation).
    dealii::TrilinosWrappers::PreconditionAMG  amg;
    std::vector<double>                        vertex_near_null_space;
    std::shared_ptr<const dealii::TrilinosWrappers::SparseMatrix> prolongation;
    std::unique_ptr<VertexTwoLevel>            vertex_two_level;
    const Epetra_Operator &amg_operator() const
    {
      return vertex_two_level ? static_cast<const Epetra_Operator &>(*vertex_two_level) : amg.trilinos_operator();
    }
    std::unique_ptr<Deflation>                 deflation; // by the modes, once they are known
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
                         const ProjectedAmg &preconditioner, std::vector<double> &eigenvalues,
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
      const ProjectedAmg preconditioner(amg_operator(), constrained, &constrained_diagonal,
                                        "block CG of " + std::to_string(X.NumVectors()) + " columns", progress,
                                        deflation.get());
      X.PutScalar(0.); // the first preconditioned residual holds the solution's part in span Z
      Belos::LinearProblem<double, MV, OP> problem(Teuchos::rcp(A_product.get(), false),
                                                   Teuchos::rcp(&X, false), Teuchos::rcp(&B, false));
      problem.setLeftPrec(Teuchos::rcp(&preconditioner, false));
      AssertThrow(problem.setProblem(), ExcMessage("Belos could not set up the static solves' linear problem."));
      auto parameters = Teuchos::rcp(new Teuchos::ParameterList);
      parameters->set("Block Size", X.NumVectors());
      parameters->set("Maximum Iterations", 20000);
      parameters->set("Convergence Tolerance", 1e-12);
      parameters->set("Implicit Residual Scaling", std::string("Norm of RHS"));
      Belos::BlockCGSolMgr<double, MV, OP> solver(Teuchos::rcp(&problem, false), parameters);
      const Belos::ReturnType converged = solver.solve();
      AssertThrow(converged == Belos::Converged,
                  ExcMessage("The AMG-preconditioned block CG of the static solves did not converge: relative "
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
      deflation = std::make_unique<Deflation>(*A_product, std::move(modes));
      stats.deflation_modes   = deflation->size();
      stats.deflation_seconds = timer.wall_time();
    }
  };

  void AmgShiftedInverse::Impl::set_up(const double shift_, const std::vector<unsigned int> &constrained_,
                                       const bool node_blocked, const VertexSpaceTransfer *vertex_space)
  {
    AssertThrow(shift_ <= 0., ExcMessage("The LOBPCG + AMG eigensolver needs 'Modes/Shift' <= 0 (K - shift M must "
                                         "be positive definite for the AMG and CG); it is " +
                                         std::to_string(std::sqrt(shift_) / (2. * M_PI)) + " Hz."));
    shift       = shift_;
    constrained = constrained_;
    A_product   = std::make_unique<ThreadedMatrix>(A->trilinos_matrix());
    M_product   = std::make_unique<ThreadedMatrix>(M->trilinos_matrix());
    Epetra_Vector diagonal(A->trilinos_matrix().RowMap());
    A->trilinos_matrix().ExtractDiagonalCopy(diagonal);
    for (const unsigned int k : constrained)
      constrained_diagonal.push_back(diagonal[k]);

    const std::size_t n_local = A->local_size();
    for (unsigned int j = 0; j < 6; ++j)
      for (const unsigned int k : constrained)
        near_null_space[j * n_local + k] = 0.;
    if (vertex_space == nullptr)
      {
        amg.initialize(*A, ml_parameters(near_null_space, node_blocked, A->m()));
        return;
      }
    vertex_near_null_space = vertex_space->near_null_space;
    prolongation           = vertex_space->prolongation;
    vertex_two_level       = std::make_unique<VertexTwoLevel>(
      A->trilinos_matrix(), *A_product, prolongation->trilinos_matrix(),
      ml_parameters(vertex_near_null_space, vertex_space->node_blocked, prolongation->n()));
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::SparseMatrix<double>           &K,
                                       const dealii::SparseMatrix<double>           &M,
                                       const double                                  shift,
                                       const std::array<dealii::Vector<double>, 6> &rigid_body_motions,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const VertexSpaceTransfer                    *vertex_space)
    : impl(std::make_unique<Impl>())
  {
    dealii::Timer timer;
    // Drop tolerance 0: deal.II's default drops entries below 1e-13 in absolute value, which a
    // mass matrix in SI units of a small part can hold.
    impl->own_A.reinit(K, 0.);
    impl->own_M.reinit(M, 0.);
    if (shift != 0.)
      impl->own_A.add(-shift, impl->own_M);
    impl->A = &impl->own_A, impl->M = &impl->own_M;
    const std::size_t n = K.m();
    impl->near_null_space.resize(6 * n);
    for (unsigned int j = 0; j < 6; ++j)
      std::copy(rigid_body_motions[j].begin(), rigid_body_motions[j].end(), impl->near_null_space.begin() + j * n);
    impl->set_up(shift, constrained, node_blocked, vertex_space);
    describe(node_blocked, timer.wall_time());
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::TrilinosWrappers::SparseMatrix &K,
                                       const dealii::TrilinosWrappers::SparseMatrix &M,
                                       const double                                  shift,
                                       std::vector<double>                           near_null_space,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const VertexSpaceTransfer                    *vertex_space)
    : impl(std::make_unique<Impl>())
  {
    dealii::Timer timer;
    impl->A = &K, impl->M = &M;
    if (shift != 0.)
      {
        impl->own_A.copy_from(K);
        impl->own_A.add(-shift, M);
        impl->A = &impl->own_A;
      }
    impl->near_null_space = std::move(near_null_space);
    impl->set_up(shift, constrained, node_blocked, vertex_space);
    describe(node_blocked, timer.wall_time());
  }

  void AmgShiftedInverse::describe(const bool node_blocked, const double setup_seconds)
  {
    stats.method = std::string("amg-block-cg (Trilinos ML smoothed aggregation, rigid-body near-null space") +
                   (node_blocked ? ", 3 DoFs per node" : ", DoF-wise aggregation") +
                   (impl->vertex_two_level ? ", on the vertex (P1) space under " + impl->vertex_two_level->smoother_interval() + ")" :
                                             std::string(")"));
    stats.analyze_seconds = setup_seconds;
  }

  AmgShiftedInverse::~AmgShiftedInverse() = default;

  const AmgSolverStatistics &AmgShiftedInverse::amg_statistics() const { return impl->stats; }

  std::string AmgShiftedInverse::preconditioner_name() const
  {
    return "AMG (ML, rigid-body near-null space" +
           (impl->vertex_two_level ? "; on the vertex space, " + impl->vertex_two_level->smoother_interval() : "") + ")";
  }

  std::string AmgShiftedInverse::eigensolver_method() const
  {
    const unsigned int runs = impl->stats.n_lobpcg_runs;
    return "LOBPCG (Trilinos Anasazi" +
           (runs > 1 ? ", " + std::to_string(runs) + " runs of at most " + std::to_string(impl->stats.modes_per_run) +
                         " modes" :
                       std::string()) +
           ") + AMG (Trilinos ML), no factorization";
  }

  void AmgShiftedInverse::deflate_by_modes(const std::vector<dealii::Vector<double>> &modes)
  {
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector Z(map, int(modes.size()), false);
    for (std::size_t c = 0; c < modes.size(); ++c)
      std::copy(modes[c].begin(), modes[c].end(), Z[c]);
    impl->deflate(std::move(Z));
  }

  void AmgShiftedInverse::deflate_by_modes(const std::vector<dealii::TrilinosWrappers::MPI::Vector> &modes)
  {
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector Z(map, int(modes.size()), false);
    for (std::size_t c = 0; c < modes.size(); ++c)
      {
        const Epetra_MultiVector &mode = modes[c].trilinos_vector();
        AssertThrow(mode.MyLength() == Z.MyLength(), ExcMessage("A mode's rows differ from the matrix's."));
        std::copy(mode[0], mode[0] + mode.MyLength(), Z[c]);
      }
    impl->deflate(std::move(Z));
  }

  // The columns are solved together by block CG.
  void AmgShiftedInverse::solve_block(double *columns, const unsigned int n_rhs)
  {
    if (n_rhs == 0)
      return;
    dealii::Timer            timer;
    const std::size_t        n   = impl->A->m();
    const Epetra_Map        &map = impl->A->trilinos_matrix().OperatorDomainMap();
    const Epetra_MultiVector B(Copy, map, columns, int(n), int(n_rhs));
    Epetra_MultiVector       X(View, map, columns, int(n), int(n_rhs));
    impl->block_conjugate_gradients(X, B);
    stats.solve_seconds += timer.wall_time();
    stats.n_solved_vectors += n_rhs;
  }

  // The columns (this process's rows of each) copied into one block and solved together.
  void AmgShiftedInverse::solve_columns(std::vector<dealii::TrilinosWrappers::MPI::Vector> &columns)
  {
    if (columns.empty())
      return;
    dealii::Timer      timer;
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector B(map, int(columns.size())), X(map, int(columns.size()));
    for (std::size_t c = 0; c < columns.size(); ++c)
      {
        const Epetra_MultiVector &column = columns[c].trilinos_vector();
        AssertThrow(column.MyLength() == B.MyLength(), ExcMessage("A right-hand side's rows differ from the matrix's."));
        std::copy(column[0], column[0] + column.MyLength(), B[c]);
      }
    impl->block_conjugate_gradients(X, B);
    for (std::size_t c = 0; c < columns.size(); ++c)
      std::copy(X[c], X[c] + X.MyLength(), columns[c].trilinos_vector()[0]);
    stats.solve_seconds += timer.wall_time();
    stats.n_solved_vectors += columns.size();
  }

  namespace
  {
    // LOBPCG's block for 'count' wanted modes: a little larger, so that the convergence factor of
    // the last wanted pair is set by the gap to the first unwanted one inside the block.
    int lobpcg_block(const int count) { return count + std::max(4, count / 4); }

    // What one solver run may take on this process: half of its share of the memory its node
    // has available now, the smallest over the processes (so that all decide alike).
    double memory_budget(const MPI_Comm comm) { return memory_budget_per_process_bytes(0., comm); }

    // Bytes per row that one LOBPCG run holds for a block of b columns: Anasazi's twelve blocks
    // (X, H, P and their A and M products, the residual, a work block, the start), the
    // preconditioner's three work blocks and the products' buffers, measured as 18.5 b doubles
    // per row on the P2 plate at np = 2 (1.2 GB per 131k rows for b = 62).
    double lobpcg_bytes_per_row(const int b) { return 19. * b * sizeof(double); }

    // The most modes one run may seek: all of them if their run fits half of this process's share
    // of the node's available memory, else as many as fit (at least 8). Runs after the first seek
    // their modes in the complement of the earlier ones: smaller blocks, more iterations and more
    // time (docs/performance.md, "LOBPCG + AMG where no factor fits"), but a part twice the size fits.
    int modes_fitting_one_run(const int n_modes, const std::size_t n_rows, const MPI_Comm comm)
    {
      const double budget = memory_budget(comm) - double(n_modes) * n_rows * sizeof(double); // the modes found
      int count = n_modes;
      while (count > 8 && lobpcg_bytes_per_row(lobpcg_block(count)) * n_rows > budget)
        --count;
      return count;
    }
  } // namespace

  // A block CG's work space per right-hand side is about 13 doubles per row: Belos' blocks (the
  // residual, the preconditioned residual, the direction and A times it), the copies in and out,
  // the smoother's, the two levels' and the deflation's work blocks (measured 12.6 on the P2 plate
  // at np = 2: 0.63 GB for 48 columns of 131k rows per process).
  unsigned int AmgShiftedInverse::columns_fitting_one_solve(const unsigned int wanted) const
  {
    const double       bytes_per_column = 13. * sizeof(double) * impl->A->local_size();
    const unsigned int fitting = memory_budget(impl->A->get_mpi_communicator()) / bytes_per_column;
    return std::clamp(fitting, 1u, wanted);
  }

  namespace
  {
    using Lobpcg = Anasazi::LOBPCG<double, Epetra_MultiVector, Epetra_Operator>;

    // LOBPCG afresh from its current Ritz vectors, without the search directions P.
    void restart_from_ritz_vectors(Lobpcg &lobpcg)
    {
      Anasazi::LOBPCGState<double, Epetra_MultiVector> restart;
      restart.X = Teuchos::rcp(new Epetra_MultiVector(*lobpcg.getState().X)); // the state is a view
      lobpcg.initialize(restart);
    }

    // LOBPCG's iterations until its status test passes (true), or until the Rayleigh-Ritz basis
    // has lost its rank twice in a row (false). [X H P] becomes singular when pairs that have
    // converged keep round-off-sized residuals in the block; Anasazi then throws, and its solver
    // manager gives up under full orthogonalization, losing the run. The first time, LOBPCG
    // restarts from its Ritz vectors without P; if [X H] is singular too, the caller keeps what
    // has converged. (At 2.15 M P2 DoFs the basis was lost at iteration 62 with no pair converged:
    // an indefinite smoother, since bounded safely, VertexTwoLevel::set_up_smoother.)
    bool iterate_until_basis_lost(Lobpcg &lobpcg, const std::function<void(const std::string &)> &progress)
    {
      int lost_at = -2;
      for (;;)
        try
          {
            lobpcg.iterate();
            return true;
          }
        catch (const Anasazi::AnasaziError &failure)
          {
            const bool basis_lost = dynamic_cast<const Anasazi::LOBPCGOrthoFailure *>(&failure) != nullptr ||
                                    dynamic_cast<const Anasazi::LOBPCGRitzFailure *>(&failure) != nullptr;
            AssertThrow(basis_lost, ExcMessage("LOBPCG + AMG stopped at iteration " +
                                               std::to_string(lobpcg.getNumIters()) + ": " + failure.what()));
            restart_from_ritz_vectors(lobpcg); // Ritz values and residuals of the last good iteration
            if (lobpcg.getNumIters() <= lost_at + 1)
              return false;
            lost_at = lobpcg.getNumIters();
            if (progress)
              progress("LOBPCG: the basis [X H P] lost its rank at iteration " + std::to_string(lost_at) +
                       "; restarted from the current Ritz vectors");
          }
    }

    std::string to_string_scientific(const double value)
    {
      std::ostringstream text;
      text << std::setprecision(2) << std::scientific << value;
      return text.str();
    }

    using LobpcgBase = Anasazi::Eigensolver<double, Epetra_MultiVector, Epetra_Operator>;

    // The block's columns in ascending order of their Ritz values.
    std::vector<int> ascending_ritz_order(LobpcgBase &solver)
    {
      const auto       values = solver.getRitzValues();
      std::vector<int> order(values.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](int a, int b) { return values[a].realpart < values[b].realpart; });
      return order;
    }

    // The relative residuals ||A x - theta M x|| / theta of the block's Ritz pairs, lowest pair
    // first, in the self-checks' measure (Anasazi's, which is per unit mass, divided by 'scale',
    // the square root of the mean mass per DoF).
    std::vector<double> relative_residuals(LobpcgBase &solver, const double scale)
    {
      const auto          values = solver.getRitzValues();
      const auto          norms  = solver.getRes2Norms();
      std::vector<double> residuals;
      for (const int j : ascending_ritz_order(solver))
        residuals.push_back(norms[j] / std::abs(values[j].realpart) / scale);
      return residuals;
    }

    // The block's columns whose Ritz pairs are the lowest and have converged to 'tolerance'
    // (relative_residuals' measure), lowest first: up to the first that has not.
    std::vector<int> lowest_converged(LobpcgBase &solver, const double tolerance, const double scale)
    {
      const auto       residuals = relative_residuals(solver, scale);
      const auto       order     = ascending_ritz_order(solver);
      std::vector<int> converged;
      while (converged.size() < order.size() && residuals[converged.size()] <= tolerance)
        converged.push_back(order[converged.size()]);
      return converged;
    }

    // A progress line every 30 s of a LOBPCG run: its iteration, how many of the wanted pairs have
    // converged from the lowest up, the residual of the lowest that has not, the preconditioner's
    // applications. It never stops the run (a status test in Anasazi's OR combination).
    class LobpcgProgress : public Anasazi::StatusTest<double, Epetra_MultiVector, Epetra_Operator>
    {
    public:
      LobpcgProgress(const int wanted, const double tolerance, const double scale, const ProjectedAmg &preconditioner,
                     std::function<void(const std::string &)> progress)
        : wanted(wanted), tolerance(tolerance), scale(scale), preconditioner(preconditioner),
          progress(std::move(progress))
      {}

      Anasazi::TestStatus checkStatus(LobpcgBase *solver) override
      {
        if (progress && since_progress.wall_time() > 30.)
          {
            const auto residuals = relative_residuals(*solver, scale);
            const int  converged = std::min<int>(wanted, lowest_converged(*solver, tolerance, scale).size());
            progress("LOBPCG: iteration " + std::to_string(solver->getNumIters()) + ", " + std::to_string(converged) +
                     " of " + std::to_string(wanted) + " converged" +
                     (converged < int(residuals.size()) ?
                        ", the next at relative residual " + to_string_scientific(residuals[converged]) :
                        std::string()) +
                     "; " + std::to_string(preconditioner.n_applications) + " preconditioner applications, " +
                     std::to_string(int(total.wall_time())) + " s");
            since_progress.restart();
          }
        return Anasazi::Failed;
      }
      Anasazi::TestStatus getStatus() const override { return Anasazi::Failed; }
      std::vector<int> whichVecs() const override { return {}; }
      int howMany() const override { return 0; }
      void reset() override {}
      void clearStatus() override {}
      std::ostream &print(std::ostream &out, int) const override { return out << "LOBPCG progress lines\n"; }

    private:
      const int                                      wanted;
      const double                                   tolerance, scale;
      const ProjectedAmg                            &preconditioner;
      const std::function<void(const std::string &)> progress;
      dealii::Timer                                  total, since_progress;
    };

    // Eigenvalues of K from those of A = K - shift M, ascending.
    std::vector<double> of_K(std::vector<double> of_A, const double shift)
    {
      for (double &lambda : of_A)
        lambda += shift;
      std::sort(of_A.begin(), of_A.end());
      return of_A;
    }

    // Passes once the run's lowest converged pairs (lowest_converged), with the modes of the earlier
    // runs, decide the cut-off's count (CutOffStop): the run then ends short of its count. LOBPCG
    // minimizes the Rayleigh quotient over its block: its lowest pairs converge first, and its i-th
    // Ritz value bounds the i-th eigenvalue from above (Courant-Fischer). Stopping where the converged
    // lowest hold the floor and one above the cut-off trusts what every count of LOBPCG's trusts:
    // that the block has not missed a mode below its converged ones (a random start, a block larger
    // than the count; a later run, in the complement, would find a missed one first). The shift plays
    // no part here (LOBPCG seeks the smallest of A = K - shift M, whatever shift <= 0).
    class CutOffDecided : public Anasazi::StatusTest<double, Epetra_MultiVector, Epetra_Operator>
    {
    public:
      // earlier: the eigenvalues of K found by the earlier runs; shift: A = K - shift M.
      CutOffDecided(const CutOffStop &stop, const unsigned int n_modes, std::vector<double> earlier, const double shift,
                    const int wanted, const double tolerance, const double scale)
        : stop(stop), n_modes(n_modes), earlier(std::move(earlier)), shift(shift), wanted(wanted),
          tolerance(tolerance), scale(scale)
      {}

      Anasazi::TestStatus checkStatus(LobpcgBase *solver) override
      {
        std::vector<double> lowest = earlier;
        const auto          values = solver->getRitzValues();
        const auto          converged = lowest_converged(*solver, tolerance, scale);
        for (std::size_t k = 0; k < converged.size() && int(k) < wanted; ++k)
          lowest.push_back(values[converged[k]].realpart + shift);
        std::sort(lowest.begin(), lowest.end());
        status = stop.decided_count(lowest, n_modes) <= lowest.size() ? Anasazi::Passed : Anasazi::Failed;
        return status;
      }
      Anasazi::TestStatus getStatus() const override { return status; }
      std::vector<int> whichVecs() const override { return {}; }
      int howMany() const override { return 0; }
      void reset() override { status = Anasazi::Undefined; }
      void clearStatus() override { status = Anasazi::Undefined; }
      std::ostream &print(std::ostream &out, int) const override { return out << "the cut-off's count decided\n"; }

    private:
      const CutOffStop          stop;
      const unsigned int        n_modes;
      const std::vector<double> earlier;
      const double              shift;
      const int                 wanted;
      const double              tolerance, scale;
      Anasazi::TestStatus       status = Anasazi::Undefined;
    };
  } // namespace

  // One LOBPCG run (Trilinos Anasazi): the 'count' lowest eigenpairs of (A, M) in the M-orthogonal
  // complement of found's first 'first' columns (the modes of earlier runs), written into its next
  // columns, their eigenvalues of A appended to 'eigenvalues'; fewer once the converged ones decide
  // the cut-off's count (CutOffDecided). It starts from 'start' (the Ritz vectors an earlier run left,
  // if any; random columns fill the block). It keeps the lowest pairs that have converged, and leaves
  // the rest of its Ritz vectors in 'start' for the next run: those of the modes above its count
  // (the block is larger), and of the modes below it where the run had to stop before all 'count'
  // converged (the basis lost, iterate_until_basis_lost).
  AmgShiftedInverse::Impl::LobpcgRun
  AmgShiftedInverse::Impl::lobpcg_run(Epetra_MultiVector &found, const int first, const int count,
                                      const double tolerance, const ProjectedAmg &preconditioner,
                                      std::vector<double> &eigenvalues, std::unique_ptr<Epetra_MultiVector> &start,
                                      const std::function<void(const std::string &)> &progress,
                                      const CutOffStop                                &stop) const
  {
    using MV = Epetra_MultiVector;
    using OP = Epetra_Operator;
    const int block_size = lobpcg_block(count);
    auto      initial    = Teuchos::rcp(new MV(found.Map(), block_size));
    initial->Random();
    for (int c = 0; start && c < std::min(block_size, start->NumVectors()); ++c)
      std::copy((*start)[c], (*start)[c] + found.MyLength(), (*initial)[c]);
    for (int c = 0; c < block_size; ++c)
      for (const unsigned int i : constrained)
        (*initial)[c][i] = 0.;

    const MassWatchingLobpcg mass(*M_product, preconditioner, block_size);
    auto problem = Teuchos::rcp(new Anasazi::BasicEigenproblem<double, MV, OP>(
      Teuchos::rcp(A_product.get(), false), Teuchos::rcp(const_cast<MassWatchingLobpcg *>(&mass), false), initial));
    problem->setHermitian(true);
    problem->setNEV(count);
    problem->setPrec(Teuchos::rcp(const_cast<ProjectedAmg *>(&preconditioner), false));
    if (first > 0)
      problem->setAuxVecs(Teuchos::rcp(new MV(View, found, 0, first)));
    AssertThrow(problem->setProblem(), ExcMessage("Anasazi refused the eigenproblem (LOBPCG + AMG)."));

    // Anasazi measures ||A x - theta M x|| / theta for M-normalized x; the self-checks (and the
    // direct path) divide by theta ||M x|| too, which for M ~ m I is sqrt(m) with m the mean mass
    // per DoF: the tolerance is scaled by it, so that it means the same at every unit and size.
    const double mass_scale       = std::sqrt(mean_free_diagonal(*M)); // one pass over M and a reduction
    const double scaled_tolerance = tolerance * mass_scale;
    const auto   sorter           = Teuchos::rcp(new Anasazi::BasicSort<double>("SM"));
    const auto   wanted_converged = Teuchos::rcp(new Anasazi::StatusTestWithOrdering<double, MV, OP>(
      Teuchos::rcp(new Anasazi::StatusTestResNorm<double, MV, OP>(scaled_tolerance, count, Anasazi::RES_2NORM, true)),
      sorter, count));
    const auto enough_iterations = Teuchos::rcp(new Anasazi::StatusTestMaxIters<double, MV, OP>(5000));
    const auto progress_lines =
      Teuchos::rcp(new LobpcgProgress(count, tolerance, mass_scale, preconditioner, progress));
    const auto cut_off_decided = Teuchos::rcp(new CutOffDecided(stop, found.NumVectors(), of_K(eigenvalues, shift),
                                                                shift, count, tolerance, mass_scale));
    const auto ended           = Teuchos::rcp(new Anasazi::StatusTestCombo<double, MV, OP>(
      Anasazi::StatusTestCombo<double, MV, OP>::OR,
      Teuchos::tuple<Teuchos::RCP<Anasazi::StatusTest<double, MV, OP>>>(wanted_converged, cut_off_decided,
                                                                        enough_iterations, progress_lines)));
    Teuchos::ParameterList parameters;
    parameters.set("Block Size", block_size);
    parameters.set("Full Ortho", true);
    // Without locking: Anasazi's replaces each locked pair by a random vector, which then has to
    // converge from scratch (on the P2 plate in runs of 18: over 20,000 preconditioner applications
    // instead of 4,900).
    Lobpcg lobpcg(
      problem, sorter, Teuchos::rcp(new Anasazi::OutputManager<double>(Anasazi::Errors + Anasazi::Warnings)), ended,
      Teuchos::rcp(new Anasazi::SVQBOrthoManager<double, MV, OP>(problem->getM())), parameters);
    if (first > 0)
      lobpcg.setAuxVecs(Teuchos::tuple<Teuchos::RCP<const MV>>(problem->getAuxVecs()));
    const bool       ended_by_test = iterate_until_basis_lost(lobpcg, progress);
    const int        iterations    = lobpcg.getNumIters();
    std::vector<int> keep          = lowest_converged(lobpcg, tolerance, mass_scale);
    keep.resize(std::min<std::size_t>(keep.size(), count));
    const bool decided = cut_off_decided->getStatus() == Anasazi::Passed;
    AssertThrow((ended_by_test && (int(keep.size()) == count || decided)) || (!ended_by_test && !keep.empty()),
                ExcMessage("LOBPCG + AMG found " + std::to_string(first + keep.size()) + " of " +
                           std::to_string(found.NumVectors()) + " modes in " + std::to_string(iterations) +
                           " iterations" + (ended_by_test ? "" : " (its basis lost its rank)") +
                           "; the lowest Ritz pair's relative residual is " +
                           to_string_scientific(relative_residuals(lobpcg, mass_scale)[0]) +
                           " (relative residual tolerance " + std::to_string(tolerance) +
                           "). Try a looser 'Modes/LOBPCG tolerance', or 'Modes/Eigensolver = block-krylov' (the direct "
                           "factorization) where its factor fits."));

    const auto values = lobpcg.getRitzValues();
    const auto ritz   = lobpcg.getRitzVectors();
    for (std::size_t k = 0; k < keep.size(); ++k)
      {
        eigenvalues.push_back(values[keep[k]].realpart);
        std::copy((*ritz)[keep[k]], (*ritz)[keep[k]] + found.MyLength(), found[first + k]);
      }
    std::vector<int> rest;
    for (int j = 0; j < block_size; ++j)
      if (std::find(keep.begin(), keep.end(), j) == keep.end())
        rest.push_back(j);
    start = std::make_unique<MV>(found.Map(), int(rest.size()));
    for (std::size_t c = 0; c < rest.size(); ++c)
      std::copy((*ritz)[rest[c]], (*ritz)[rest[c]] + found.MyLength(), (*start)[c]);
    if (int(keep.size()) < count && !decided && progress)
      progress("LOBPCG: run ended at iteration " + std::to_string(iterations) + " with " + std::to_string(keep.size()) +
               " of its " + std::to_string(count) + " modes converged; the next run seeks the rest from its other Ritz vectors");
    return {iterations, int(keep.size())};
  }


  EigenSolution AmgShiftedInverse::lowest_modes(const unsigned int n_modes, const double tolerance,
                                                const unsigned int                              modes_per_run,
                                                const std::function<void(const std::string &)> &progress,
                                                const CutOffStop                                &stop)
  {
    dealii::Timer timer;
    impl->progress         = progress;
    const auto   &A_epetra = impl->A->trilinos_matrix();
    const int     per_run  = modes_per_run > 0 ?
                               int(std::min(modes_per_run, n_modes)) :
                               modes_fitting_one_run(int(n_modes), A_epetra.NumMyRows(), impl->A->get_mpi_communicator());
    AssertThrow(3 * lobpcg_block(per_run) < A_epetra.NumGlobalRows(),
                ExcMessage("LOBPCG for " + std::to_string(n_modes) + " modes needs more than " +
                           std::to_string(3 * lobpcg_block(per_run)) + " DoFs; the part has " +
                           std::to_string(A_epetra.NumGlobalRows()) + ": use 'Modes/Eigensolver = block-krylov'."));
    if (per_run < int(n_modes) && progress)
      progress("LOBPCG: up to " + std::to_string((n_modes + per_run - 1) / per_run) + " runs of at most " +
               std::to_string(per_run) + " modes, each in the complement of the earlier ones' (" +
               (modes_per_run > 0 ? std::string("Modes/LOBPCG modes per run") :
                                    std::to_string(n_modes) + " at once would not fit half the available memory") +
               ")");
    // No progress lines of its own: LobpcgProgress's say more.
    ProjectedAmg        preconditioner(impl->amg_operator(), impl->constrained, nullptr, "LOBPCG", {});
    Epetra_MultiVector  found(A_epetra.OperatorDomainMap(), int(n_modes));
    std::vector<double> lambda; // of A = K - shift M
    int                 iterations = 0, runs = 0, largest_run = 0;
    std::unique_ptr<Epetra_MultiVector> start;
    // Runs as the cut-off asks (CutOffStop::next_batch: the floor and a margin first, under rule 'none'
    // all n_modes), each at most per_run; a run ends early where its converged lowest decide the count.
    for (int first = 0, batch; (batch = int(stop.next_batch(of_K(lambda, impl->shift), n_modes))) > 0; ++runs)
      {
        const int  count = std::min(per_run, batch);
        const auto run   = impl->lobpcg_run(found, first, count, tolerance, preconditioner, lambda, start, progress, stop);
        iterations += run.iterations;
        first += run.modes_found;
        largest_run = std::max(largest_run, count);
      }
    impl->stats.eigensolver_iterations = iterations;
    impl->stats.modes_per_run          = largest_run;
    impl->stats.n_lobpcg_runs          = runs;

    // Ascending over the runs too (a later run's lowest lies above an earlier run's highest unless
    // two modes are equal to the tolerance).
    std::vector<unsigned int> order(lambda.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](unsigned a, unsigned b) { return lambda[a] < lambda[b]; });
    EigenSolution eigen;
    for (const unsigned int k : order)
      {
        eigen.eigenvalues.push_back(lambda[k] + impl->shift);
        eigen.eigenvectors.emplace_back(found[k], found[k] + found.MyLength());
      }
    eigen.n_operator_applications      = preconditioner.n_applications;
    eigen.eigensolve_iteration_seconds = timer.wall_time();
    return eigen;
  }

  namespace
  {
    // weights(i, j): vertex shape function j at the support point of the space's shape function i
    // when both belong to the same displacement component (else 0): the interpolation of a linear
    // field into the space, cell by cell.
    dealii::FullMatrix<double> cell_interpolation(const dealii::FiniteElement<3> &fe,
                                                  const dealii::FiniteElement<3> &vertex_fe)
    {
      dealii::FullMatrix<double> weights(fe.n_dofs_per_cell(), vertex_fe.n_dofs_per_cell());
      for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
        for (unsigned int j = 0; j < vertex_fe.n_dofs_per_cell(); ++j)
          if (fe.system_to_component_index(i).first == vertex_fe.system_to_component_index(j).first)
            {
              const double w = vertex_fe.shape_value(j, fe.get_unit_support_points()[i]);
              weights(i, j)  = std::abs(w) < 1e-12 ? 0. : w;
            }
      return weights;
    }
  } // namespace

  bool node_blocked(const dealii::DoFHandler<3> &dof_handler, const MPI_Comm comm)
  {
    const auto                                  &fe = dof_handler.get_fe();
    std::vector<dealii::types::global_dof_index> dofs(fe.n_dofs_per_cell());
    bool                                         blocked = true;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            blocked = blocked && dofs[i] % 3 == fe.system_to_component_index(i).first;
        }
    return dealii::Utilities::MPI::min(int(blocked), comm) == 1;
  }

  VertexSpaceTransfer make_vertex_space_transfer(const dealii::DoFHandler<3>             &dof_handler,
                                                 const dealii::Mapping<3>                &mapping,
                                                 const dealii::AffineConstraints<double> &constraints,
                                                 const MPI_Comm                           comm)
  {
    using namespace dealii;
    const FESystem<3> vertex_fe(FE_SimplexP<3>(1), 3);
    DoFHandler<3>     vertex_dofs(dof_handler.get_triangulation());
    vertex_dofs.distribute_dofs(vertex_fe);
    const FiniteElement<3>   &fe           = dof_handler.get_fe();
    const IndexSet           &owned        = dof_handler.locally_owned_dofs();
    const IndexSet           &vertex_owned = vertex_dofs.locally_owned_dofs();
    const FullMatrix<double>  weights      = cell_interpolation(fe, vertex_fe);
    const std::size_t         n_vertex     = vertex_owned.n_elements();

    VertexSpaceTransfer transfer;
    transfer.near_null_space.assign(6 * n_vertex, 0.);
    std::vector<bool> held(n_vertex, false); // the space's DoF at this vertex DoF is constrained
    DynamicSparsityPattern pattern(dof_handler.n_dofs(), vertex_dofs.n_dofs(), owned);
    std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell()), vertex_dof_indices(vertex_fe.n_dofs_per_cell());
    // Both handlers walk the same cells in the same order.
    auto vertex_cell = vertex_dofs.begin_active();
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        const auto this_vertex_cell = vertex_cell++;
        if (!cell->is_locally_owned())
          continue;
        cell->get_dof_indices(dofs);
        this_vertex_cell->get_dof_indices(vertex_dof_indices);
        for (unsigned int j = 0; j < vertex_dof_indices.size(); ++j)
          {
            const types::global_dof_index g = vertex_dof_indices[j];
            const unsigned int c = vertex_fe.system_to_component_index(j).first;
            if (!vertex_owned.is_element(g))
              continue;
            const std::size_t k = vertex_owned.index_within_set(g);
            const Point<3>    x = mapping.transform_unit_to_real_cell(cell, vertex_fe.get_unit_support_points()[j]);
            for (unsigned int m = 0; m < 6; ++m)
              transfer.near_null_space[m * n_vertex + k] = rigid_body_motion(m, x)[c];
          }
        for (unsigned int i = 0; i < dofs.size(); ++i)
          if (owned.is_element(dofs[i]))
            for (unsigned int j = 0; j < vertex_dof_indices.size(); ++j)
              if (weights(i, j) != 0.)
                {
                  pattern.add(dofs[i], vertex_dof_indices[j]);
                  if (weights(i, j) == 1. && constraints.is_constrained(dofs[i]) &&
                      vertex_owned.is_element(vertex_dof_indices[j]))
                    held[vertex_owned.index_within_set(vertex_dof_indices[j])] = true;
                }
      }
    for (std::size_t k = 0; k < n_vertex; ++k)
      if (held[k])
        for (unsigned int m = 0; m < 6; ++m)
          transfer.near_null_space[m * n_vertex + k] = 0.;
    transfer.node_blocked = node_blocked(vertex_dofs, comm);

    transfer.prolongation = std::make_shared<TrilinosWrappers::SparseMatrix>();
    TrilinosWrappers::SparseMatrix &P = *transfer.prolongation;
    P.reinit(owned, vertex_owned, pattern, comm);
    vertex_cell = vertex_dofs.begin_active();
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        const auto this_vertex_cell = vertex_cell++;
        if (!cell->is_locally_owned())
          continue;
        cell->get_dof_indices(dofs);
        this_vertex_cell->get_dof_indices(vertex_dof_indices);
        for (unsigned int i = 0; i < dofs.size(); ++i)
          if (owned.is_element(dofs[i]))
            for (unsigned int j = 0; j < vertex_dof_indices.size(); ++j)
              if (weights(i, j) != 0.)
                P.set(dofs[i], vertex_dof_indices[j], weights(i, j));
      }
    P.compress(VectorOperation::insert);
    return transfer;
  }
} // namespace modal_haptics
