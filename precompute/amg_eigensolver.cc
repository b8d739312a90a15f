// LOBPCG + AMG (amg_eigensolver.h): Trilinos Anasazi's LOBPCG on (K - shift M, M), ML's
// smoothed aggregation with the rigid-body near-null space as its preconditioner, and Belos' block
// CG with the same preconditioner for the static solves.
#include "amg_eigensolver.h"

#include "blas_lapack.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <AnasaziBasicEigenproblem.hpp>
#include <AnasaziEpetraAdapter.hpp>
#include <AnasaziLOBPCGSolMgr.hpp>
#include <BelosBlockCGSolMgr.hpp>
#include <BelosEpetraAdapter.hpp>
#include <BelosLinearProblem.hpp>
#include <Epetra_LocalMap.h>
#include <Epetra_MultiVector.h>
#include <Epetra_Operator.h>
#include <Epetra_Vector.h>
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>
#include <ml_MultiLevelPreconditioner.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>

namespace modal_haptics
{
  using dealii::ExcMessage;

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
    class ProjectedAmg : public Epetra_Operator
    {
    public:
      // constrained_diagonal: A's diagonal on the constrained rows, or null for zero there;
      // deflation: when given, the AMG inside the deflated preconditioner (Deflation::apply).
      ProjectedAmg(const Epetra_Operator &amg, const std::vector<unsigned int> &constrained,
                   const std::vector<double> *constrained_diagonal, std::string what,
                   std::function<void(const std::string &)> progress, const Deflation *deflation = nullptr)
        : amg(amg), constrained(constrained), constrained_diagonal(constrained_diagonal), what(std::move(what)),
          progress(std::move(progress)), deflation(deflation)
      {}

      int Apply(const Epetra_MultiVector &X, Epetra_MultiVector &Y) const override
      {
        if (deflation == nullptr)
          return apply_amg(X, Y);
        return deflation->apply([this](const Epetra_MultiVector &R, Epetra_MultiVector &Z) { return apply_amg(R, Z); },
                                X, Y);
      }
      int ApplyInverse(const Epetra_MultiVector &, Epetra_MultiVector &) const override { return -1; }
      int SetUseTranspose(bool) override { return -1; }
      double NormInf() const override { return 0.; }
      const char *Label() const override { return "AMG (ML) on the free DoFs"; }
      bool UseTranspose() const override { return false; }
      bool HasNormInf() const override { return false; }
      const Epetra_Comm &Comm() const override { return amg.Comm(); }
      const Epetra_Map &OperatorDomainMap() const override { return amg.OperatorDomainMap(); }
      const Epetra_Map &OperatorRangeMap() const override { return amg.OperatorRangeMap(); }

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

  struct AmgShiftedInverse::Impl
  {
    double                                     shift = 0.;
    std::vector<unsigned int>                  constrained;          // local rows
    std::vector<double>                        constrained_diagonal; // A's, on the constrained rows
    dealii::TrilinosWrappers::SparseMatrix     own_A, own_M;         // the copies it holds, when it holds them
    const dealii::TrilinosWrappers::SparseMatrix *A = nullptr, *M = nullptr; // A = K - shift M
    std::vector<double>                        near_null_space; // six columns, read by ML while it sets up
    dealii::TrilinosWrappers::PreconditionAMG  amg;
    std::unique_ptr<Deflation>                 deflation; // by the modes, once they are known
    AmgSolverStatistics                        stats;
    unsigned long                              total_cg_iterations = 0;

    void set_up(double shift, const std::vector<unsigned int> &constrained, bool node_blocked, bool higher_order);

    // A X = B by block CG (Trilinos Belos) from zero, preconditioned by the AMG and deflated by
    // the modes once they are known, every column to 1e-12 of its load. One block Krylov space for
    // all the columns: each iteration applies A and the V-cycle to the whole block at once.
    void block_conjugate_gradients(Epetra_MultiVector &X, const Epetra_MultiVector &B)
    {
      using MV = Epetra_MultiVector;
      using OP = Epetra_Operator;
      // No progress lines: a block's solve takes seconds (finish() reports the solves' totals).
      const ProjectedAmg preconditioner(amg.trilinos_operator(), constrained, &constrained_diagonal, "block CG", {},
                                        deflation.get());
      X.PutScalar(0.); // the first preconditioned residual holds the solution's part in span Z
      Belos::LinearProblem<double, MV, OP> problem(Teuchos::rcp(&A->trilinos_matrix(), false),
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
      deflation = std::make_unique<Deflation>(A->trilinos_matrix(), std::move(modes));
      stats.deflation_modes   = deflation->size();
      stats.deflation_seconds = timer.wall_time();
    }
  };

  void AmgShiftedInverse::Impl::set_up(const double shift_, const std::vector<unsigned int> &constrained_,
                                       const bool node_blocked, const bool higher_order)
  {
    AssertThrow(shift_ <= 0., ExcMessage("The LOBPCG + AMG eigensolver needs 'Modes/Shift' <= 0 (K - shift M must "
                                         "be positive definite for the AMG and CG); it is " +
                                         std::to_string(std::sqrt(shift_) / (2. * M_PI)) + " Hz."));
    shift       = shift_;
    constrained = constrained_;
    Epetra_Vector diagonal(A->trilinos_matrix().RowMap());
    A->trilinos_matrix().ExtractDiagonalCopy(diagonal);
    for (const unsigned int k : constrained)
      constrained_diagonal.push_back(diagonal[k]);

    const std::size_t n_local = A->local_size();
    for (unsigned int j = 0; j < 6; ++j)
      for (const unsigned int k : constrained)
        near_null_space[j * n_local + k] = 0.;
    Teuchos::ParameterList ml;
    ML_Epetra::SetDefaults("SA", ml);
    ml.set("ML output", 0);
    ml.set("PDE equations", node_blocked ? 3 : 1);
    ml.set("null space: type", "pre-computed");
    ml.set("null space: dimension", 6);
    ml.set("null space: vectors", near_null_space.data());
    ml.set("aggregation: type", "Uncoupled");
    ml.set("smoother: type", "Chebyshev");
    ml.set("smoother: sweeps", higher_order ? 3 : 2);
    ml.set("coarse: type", "Amesos-KLU");
    // A coarse level of at most a tenth of the DoFs (and at most 1000): on a small part a coarse
    // level holding everything makes the AMG an exact solve, and LOBPCG, converging in a step or
    // two, breaks down on its linearly dependent search directions (seen at 1047 DoFs).
    ml.set("coarse: max size", int(std::clamp<std::size_t>(A->m() / 10, 60, 1000)));
    amg.initialize(*A, ml);
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::SparseMatrix<double>           &K,
                                       const dealii::SparseMatrix<double>           &M,
                                       const double                                  shift,
                                       const std::array<dealii::Vector<double>, 6> &rigid_body_motions,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const bool                                    higher_order)
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
    impl->set_up(shift, constrained, node_blocked, higher_order);
    describe(node_blocked, timer.wall_time());
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::TrilinosWrappers::SparseMatrix &K,
                                       const dealii::TrilinosWrappers::SparseMatrix &M,
                                       const double                                  shift,
                                       std::vector<double>                           near_null_space,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const bool                                    higher_order)
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
    impl->set_up(shift, constrained, node_blocked, higher_order);
    describe(node_blocked, timer.wall_time());
  }

  void AmgShiftedInverse::describe(const bool node_blocked, const double setup_seconds)
  {
    stats.method = std::string("amg-block-cg (Trilinos ML smoothed aggregation, rigid-body near-null space") +
                   (node_blocked ? ", 3 DoFs per node)" : ", DoF-wise aggregation)");
    stats.analyze_seconds = setup_seconds;
  }

  AmgShiftedInverse::~AmgShiftedInverse() = default;

  const AmgSolverStatistics &AmgShiftedInverse::amg_statistics() const { return impl->stats; }

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

  EigenSolution AmgShiftedInverse::lowest_modes(const unsigned int n_modes, const double tolerance,
                                                const std::function<void(const std::string &)> &progress)
  {
    using MV = Epetra_MultiVector;
    using OP = Epetra_Operator;
    dealii::Timer timer;
    const auto   &A_epetra = impl->A->trilinos_matrix();
    const auto   &M_epetra = impl->M->trilinos_matrix();
    // A block a little larger than the wanted count: the convergence factor of the last wanted
    // pair is set by the gap to the first unwanted one inside the block.
    const int block_size = int(n_modes + std::max(4u, n_modes / 4));
    AssertThrow(3 * block_size < A_epetra.NumGlobalRows(),
                ExcMessage("LOBPCG for " + std::to_string(n_modes) + " modes needs more than " +
                           std::to_string(3 * block_size) + " DoFs; the part has " +
                           std::to_string(A_epetra.NumGlobalRows()) + ": use 'Modes/Eigensolver = block-krylov'."));
    auto      initial    = Teuchos::rcp(new MV(A_epetra.OperatorDomainMap(), block_size));
    initial->Random();
    for (int c = 0; c < block_size; ++c)
      for (const unsigned int i : impl->constrained)
        (*initial)[c][i] = 0.;

    ProjectedAmg preconditioner(impl->amg.trilinos_operator(), impl->constrained, nullptr, "LOBPCG", progress);
    auto problem = Teuchos::rcp(new Anasazi::BasicEigenproblem<double, MV, OP>(
      Teuchos::rcp(const_cast<Epetra_CrsMatrix *>(&A_epetra), false),
      Teuchos::rcp(const_cast<Epetra_CrsMatrix *>(&M_epetra), false), initial));
    problem->setHermitian(true);
    problem->setNEV(int(n_modes));
    problem->setPrec(Teuchos::rcp(&preconditioner, false));
    AssertThrow(problem->setProblem(), ExcMessage("Anasazi refused the eigenproblem (LOBPCG + AMG)."));

    Teuchos::ParameterList parameters;
    parameters.set("Which", std::string("SM"));
    parameters.set("Block Size", block_size);
    parameters.set("Maximum Iterations", 5000);
    // Anasazi measures ||A x - theta M x|| / theta for M-normalized x; the self-checks (and the
    // direct path) divide by theta ||M x|| too, which for M ~ m I is sqrt(m) with m the mean mass
    // per DoF: the tolerance is scaled by it, so that it means the same at every unit and size.
    const double scaled_tolerance = tolerance * std::sqrt(mean_free_diagonal(*impl->M));
    parameters.set("Convergence Tolerance", scaled_tolerance);
    parameters.set("Relative Convergence Tolerance", true);
    parameters.set("Full Ortho", true);
    parameters.set("Use Locking", true);
    parameters.set("Locking Tolerance", scaled_tolerance / 10.);
    parameters.set("Verbosity", int(Anasazi::Errors + Anasazi::Warnings));
    Anasazi::LOBPCGSolMgr<double, MV, OP> solver(problem, parameters);
    const Anasazi::ReturnType             outcome    = solver.solve();
    const int                             iterations = solver.getNumIters();
    const auto               &solution = problem->getSolution();
    AssertThrow(outcome == Anasazi::Converged && solution.numVecs >= int(n_modes),
                ExcMessage("LOBPCG + AMG converged " + std::to_string(solution.numVecs) + " of " +
                           std::to_string(n_modes) + " modes in " + std::to_string(iterations) +
                           " iterations (relative residual tolerance " + std::to_string(tolerance) +
                           "). Try a looser 'Modes/LOBPCG tolerance', or 'Modes/Eigensolver = block-krylov' (the direct "
                           "factorization) where its factor fits."));

    std::vector<int> order(solution.numVecs);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return solution.Evals[a].realpart < solution.Evals[b].realpart; });
    EigenSolution eigen;
    const std::size_t n = A_epetra.NumMyRows();
    for (unsigned int k = 0; k < n_modes; ++k)
      {
        const int j = order[k];
        eigen.eigenvalues.push_back(solution.Evals[j].realpart + impl->shift);
        dealii::Vector<double> phi(n);
        const double          *column = (*solution.Evecs)[j]; // index[] marks complex pairs, not columns
        std::copy(column, column + n, phi.begin());
        eigen.eigenvectors.push_back(std::move(phi));
      }
    impl->stats.eigensolver_iterations = iterations;
    eigen.n_operator_applications      = preconditioner.n_applications;
    eigen.eigensolve_iteration_seconds = timer.wall_time();
    return eigen;
  }
} // namespace modal_haptics
