// LOBPCG on the AMG path (amg_eigensolver.h): Trilinos Anasazi's LOBPCG on (K - shift M, M)
// preconditioned by the AMG, in runs sized to the memory at hand, each continuing from the Ritz
// vectors the last one left, until the modes asked for (or the cut-off's count) have converged.
#include "solvers/amg_parts.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using namespace amg;

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

    // LOBPCG's first block: the Ritz vectors an earlier run left in 'start' (if any), random columns
    // after them, zero on the constrained rows.
    Teuchos::RCP<Epetra_MultiVector> initial_block(const Epetra_BlockMap &map, const int block_size,
                                                   const Epetra_MultiVector        *start,
                                                   const std::vector<unsigned int> &constrained)
    {
      auto initial = Teuchos::rcp(new Epetra_MultiVector(map, block_size));
      initial->Random();
      for (int c = 0; start && c < std::min(block_size, start->NumVectors()); ++c)
        std::copy((*start)[c], (*start)[c] + initial->MyLength(), (*initial)[c]);
      for (int c = 0; c < block_size; ++c)
        for (const unsigned int i : constrained)
          (*initial)[c][i] = 0.;
      return initial;
    }

    // The kept Ritz pairs into found's columns from 'first' on (their values appended to
    // 'eigenvalues'), the block's other Ritz vectors into 'start' for the next run.
    void take_ritz_pairs(Lobpcg &lobpcg, const std::vector<int> &keep, const int block_size, const int first,
                         Epetra_MultiVector &found, std::vector<double> &eigenvalues,
                         std::unique_ptr<Epetra_MultiVector> &start)
    {
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
      start = std::make_unique<Epetra_MultiVector>(found.Map(), int(rest.size()));
      for (std::size_t c = 0; c < rest.size(); ++c)
        std::copy((*ritz)[rest[c]], (*ritz)[rest[c]] + found.MyLength(), (*start)[c]);
    }
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
    auto      initial    = initial_block(found.Map(), block_size, start.get(), constrained);

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

    take_ritz_pairs(lobpcg, keep, block_size, first, found, eigenvalues, start);
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
} // namespace modal_haptics
