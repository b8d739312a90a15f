#include "solvers/mumps_inverse.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_solver.h>

#include <Epetra_CrsMatrix.h>
#include <Epetra_FEVector.h>
#include <Epetra_MpiComm.h>
#include <dmumps_c.h>
#include <mpi.h>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using dealii::TrilinosWrappers::MPI::Vector;

  void DistributedInverse::solve_columns(std::vector<Vector> &columns) const
  {
    if (columns.empty())
      return;
    Vector solution(columns.front().locally_owned_elements(), columns.front().get_mpi_communicator());
    for (auto &column : columns)
      {
        vmult(solution, column);
        column = solution;
      }
  }

  namespace
  {
    // A NaN or infinity out of a solve would otherwise surface far away (PARPACK's "info -9999"
    // after DLASCL complaints): said here, where it appears, with whether the right-hand sides
    // already had one. One pass over the local entries, small beside the solve.
    bool all_finite(const double *values, const std::size_t count)
    {
      return std::all_of(values, values + count, [](const double v) { return std::isfinite(v); });
    }

    void expect_finite_solution(const double *solution, const std::size_t count, const bool loads_finite,
                                const MPI_Comm comm)
    {
      if (all_finite(solution, count))
        return;
      AssertThrow(false, ExcMessage("MUMPS's solve returned a non-finite value on process " +
                                    std::to_string(dealii::Utilities::MPI::this_mpi_process(comm)) +
                                    (loads_finite ? " from finite right-hand sides" :
                                                    ", whose right-hand sides were not finite either") +
                                    "."));
    }

    // Row i of E (a local index), its global columns in increasing order.
    std::vector<long long> sorted_global_row(const Epetra_CrsMatrix &E, const std::size_t i)
    {
      int     count;
      double *values;
      int    *indices;
      E.ExtractMyRowView(int(i), count, values, indices);
      std::vector<long long> columns(count);
      for (int k = 0; k < count; ++k)
        columns[k] = E.ColMap().GID64(indices[k]);
      std::sort(columns.begin(), columns.end());
      return columns;
    }

    // The nodes (node_first_rows, factorization.h) of a matrix whose processes own consecutive
    // ranges of rows in the order of their ranks: every node's first row, known to every process.
    struct DistributedNodes
    {
      std::vector<long long> first_rows;      // by global node number
      std::vector<int>       counts, offsets; // each process's nodes
      long long              n_rows = 0;

      DistributedNodes(const std::vector<std::size_t> &own_first_rows, const long long first_row,
                       const long long n_rows, const MPI_Comm comm)
        : n_rows(n_rows)
      {
        const int n_own = int(own_first_rows.size()) - 1, n_processes = dealii::Utilities::MPI::n_mpi_processes(comm);
        counts.resize(n_processes);
        offsets.assign(n_processes, 0);
        AssertThrowMPI(MPI_Allgather(&n_own, 1, MPI_INT, counts.data(), 1, MPI_INT, comm));
        for (int p = 1; p < n_processes; ++p)
          offsets[p] = offsets[p - 1] + counts[p - 1];
        std::vector<long long> own(n_own);
        for (int g = 0; g < n_own; ++g)
          own[g] = first_row + (long long)(own_first_rows[g]);
        first_rows.resize(offsets.back() + counts.back());
        AssertThrowMPI(MPI_Allgatherv(own.data(), n_own, MPI_LONG_LONG, first_rows.data(), counts.data(),
                                      offsets.data(), MPI_LONG_LONG, comm));
        AssertThrow(std::is_sorted(first_rows.begin(), first_rows.end()),
                    ExcMessage("The processes' rows are not in the order of their ranks."));
      }
      int node_of(const long long row) const
      {
        return int(std::upper_bound(first_rows.begin(), first_rows.end(), row) - first_rows.begin()) - 1;
      }
      long long end_row(const int node) const
      {
        return std::size_t(node + 1) < first_rows.size() ? first_rows[node + 1] : n_rows;
      }
    };

    // What keeps MUMPS's factor files out of directory, or empty: it must be a writable directory
    // with room for factor_bytes.
    std::string factor_directory_problem(const std::string &directory, const double factor_bytes)
    {
      std::error_code error;
      if (!std::filesystem::is_directory(directory, error))
        return "is not a directory";
      if (access(directory.c_str(), W_OK | X_OK) != 0)
        return "is not writable";
      if (const double free = double(std::filesystem::space(directory, error).available); free < factor_bytes)
        return "has " + std::to_string(free / 1e9) + " GB free, MUMPS's factor needs about " +
               std::to_string(factor_bytes / 1e9) + " GB";
      return "";
    }

    // Each process keeps its factor files in its own subdirectory of the factor directory, named
    // after the host and its PID, and removes it with everything in it when its factorization is
    // freed. A run killed before that (Ctrl-C, the out-of-memory killer) leaves its subdirectory
    // behind, tens of GB at 10^6 DoFs: the next run on that host removes the subdirectories whose
    // process is gone, and says so.
    class PrivateFactorDirectory
    {
    public:
      // Creates it; problem says what failed (empty: nothing), for the caller's collective check.
      explicit PrivateFactorDirectory(const std::string &directory)
      {
        remove_dead_runs_files(directory);
        static unsigned int count = 0; // distinct names for the spaces of one run
        path = directory + "/" + name_prefix() + std::to_string(getpid()) + "-" + std::to_string(count++);
        std::error_code error;
        std::filesystem::create_directory(path, error);
        if (error)
          problem = "cannot hold " + path + " (" + error.message() + ")";
      }
      ~PrivateFactorDirectory()
      {
        std::error_code error;
        std::filesystem::remove_all(path, error);
      }
      PrivateFactorDirectory(const PrivateFactorDirectory &) = delete;
      PrivateFactorDirectory &operator=(const PrivateFactorDirectory &) = delete;

      std::string path, problem;

    private:
      static std::string name_prefix()
      {
        char host[256] = {};
        gethostname(host, sizeof(host) - 1);
        return std::string("modal-precompute-mumps-") + host + "-";
      }

      static void remove_dead_runs_files(const std::string &directory)
      {
        const std::string prefix = name_prefix();
        std::error_code   error;
        for (const auto &entry : std::filesystem::directory_iterator(directory, error))
          {
            const std::string name = entry.path().filename().string();
            if (name.compare(0, prefix.size(), prefix) != 0)
              continue;
            const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
            if (pid <= 0 || pid == long(getpid()) || kill(pid_t(pid), 0) == 0 || errno != ESRCH)
              continue; // a process of this host that is still alive, or not ours to judge
            std::uintmax_t bytes = 0;
            for (const auto &file : std::filesystem::recursive_directory_iterator(entry.path(), error))
              bytes += file.is_regular_file(error) ? file.file_size(error) : 0;
            std::filesystem::remove_all(entry.path(), error);
            std::cerr << "Note: removed " << entry.path().string() << " (" << double(bytes) / 1e9
                      << " GB of MUMPS's factor files left by process " << pid << ", which ended before it could)"
                      << std::endl;
          }
      }
    };

    // MUMPS's large counts (INFOG(3), INFOG(29)): in millions when negative.
    double mumps_count(const MUMPS_INT value) { return value >= 0 ? double(value) : -1e6 * double(value); }

    MPI_Datatype mpi_type(const int *) { return MPI_INT; }
    MPI_Datatype mpi_type(const double *) { return MPI_DOUBLE; }

    // Gathers each process's values onto process 0, in the processes' order (elsewhere: empty).
    template <typename T>
    std::vector<T> gather_on_host(const std::vector<T> &own, const MPI_Comm comm)
    {
      const bool       host  = dealii::Utilities::MPI::this_mpi_process(comm) == 0;
      const int        count = int(own.size());
      std::vector<int> counts(host ? dealii::Utilities::MPI::n_mpi_processes(comm) : 0), offsets(counts.size(), 0);
      AssertThrowMPI(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm));
      for (std::size_t p = 1; p < counts.size(); ++p)
        offsets[p] = offsets[p - 1] + counts[p - 1];
      std::vector<T> all(host ? offsets.back() + counts.back() : 0);
      const auto     type = mpi_type(own.data());
      AssertThrowMPI(MPI_Gatherv(own.data(), count, type, all.data(), counts.data(), offsets.data(), type, 0, comm));
      return all;
    }

    // MUMPS's pivot order (PERM_IN, each row's 1-based position; on process 0, MUMPS's host, and
    // empty elsewhere): the serial path's ordering, METIS's nested dissection of the nodes' graph
    // (factorization.h). Each process finds its own nodes among its rows and lists their neighbours;
    // the host gathers that graph (a ninth of the matrix's entries) and orders it. Debian's MUMPS is
    // built without METIS and SCOTCH: its own choice was PORD, whose factor had 7-12 % more entries
    // than this ordering's and took 7-27 % longer to compute at 406k DoFs (docs/cluster.md).
    std::vector<MUMPS_INT> node_graph_pivot_order(const Epetra_CrsMatrix &E, const long long first_row,
                                                  const MPI_Comm comm)
    {
      const auto sorted_row     = [&](const std::size_t i) { return sorted_global_row(E, i); };
      const auto own_first_rows = node_first_rows(std::size_t(E.NumMyRows()), sorted_row);
      const DistributedNodes nodes(own_first_rows, first_row, E.NumGlobalRows64(), comm);
      const NodeGraph        own =
        node_graph(own_first_rows, sorted_row, [&](const long long column) { return nodes.node_of(column); },
                   nodes.offsets[dealii::Utilities::MPI::this_mpi_process(comm)]);

      NodeGraph all{gather_on_host(own.degrees, comm), gather_on_host(own.neighbours, comm),
                    gather_on_host(own.weights, comm)};
      if (dealii::Utilities::MPI::this_mpi_process(comm) != 0)
        return {};
      std::vector<MUMPS_INT> position(nodes.n_rows);
      MUMPS_INT              next = 1;
      for (const int g : nested_dissection_of_nodes(all))
        for (long long row = nodes.first_rows[g]; row < nodes.end_row(g); ++row)
          position[row] = next++;
      return position;
    }

    // Amesos_Mumps through deal.II: MUMPS's unsymmetric LU.
    class AmesosMumpsLU : public DistributedInverse
    {
    public:
      AmesosMumpsLU(const dealii::TrilinosWrappers::SparseMatrix &A, FactorizationStatistics &stats)
        : solver(control, dealii::TrilinosWrappers::SolverDirect::AdditionalData(false, "Amesos_Mumps"))
        , stats(stats)
      {
        stats.method = "mumps-lu (Trilinos Amesos_Mumps, distributed)";
        layout.reinit(A.locally_owned_range_indices(), A.get_mpi_communicator());
        dealii::Timer timer;
        solver.initialize(A);
        stats.factorize_seconds = timer.wall_time();
      }

      void vmult(Vector &dst, const Vector &src) const override
      {
        dealii::Timer timer;
        const bool    loads_finite = all_finite(src.trilinos_vector()[0], src.locally_owned_size());
        solver.solve(dst, src);
        expect_finite_solution(dst.trilinos_vector()[0], dst.locally_owned_size(), loads_finite,
                               dst.get_mpi_communicator());
        stats.solve_seconds += timer.wall_time();
        ++stats.n_solved_vectors;
      }

      // Column by column: Amesos solves one vector at a time.
      void solve_block(double *columns, const int count) const override
      {
        const std::size_t rows = layout.locally_owned_size();
        Vector            load(layout), solution(layout);
        for (int c = 0; c < count; ++c)
          {
            std::copy(columns + c * rows, columns + (c + 1) * rows, load.trilinos_vector()[0]);
            vmult(solution, load);
            std::copy(solution.trilinos_vector()[0], solution.trilinos_vector()[0] + rows, columns + c * rows);
          }
      }

    private:
      Vector                                         layout;
      mutable dealii::SolverControl                  control;
      mutable dealii::TrilinosWrappers::SolverDirect solver;
      FactorizationStatistics                       &stats;
    };

    // MUMPS in its symmetric mode, called directly (its C interface): the distributed matrix is
    // handed over as the upper triangle's triplets, the right-hand sides stay where they are (MUMPS's
    // distributed right-hand sides, ICNTL(20) = 10, read the caller's block in place) and the
    // solution comes back distributed as MUMPS's factor is (ICNTL(21) = 1), moved to the owners of
    // its rows by one MPI_Alltoallv whose plan is kept while MUMPS's rows stay the same. PETSc's
    // MatMatSolve, the earlier way in, rebuilt and sorted that plan at every call (3 % of an np = 2
    // eigensolve's samples at 406k DoFs, docs/cluster.md) and held a second copy of the matrix.
    class MumpsCholesky : public DistributedInverse
    {
    public:
      // Copies A's upper triangle and runs MUMPS's analysis (ordering, symbolic factorization): what
      // the factor will need is known from here on (predicted_bytes_per_process), and factorize()
      // computes it.
      MumpsCholesky(const dealii::TrilinosWrappers::SparseMatrix &A, const bool positive_definite,
                    FactorizationStatistics &stats)
        : positive_definite(positive_definite)
        , stats(stats)
      {
        const Epetra_CrsMatrix &E = A.trilinos_matrix();
        // MUMPS's own communicator: its messages cannot meet Trilinos' or deal.II's.
        AssertThrowMPI(MPI_Comm_dup(dynamic_cast<const Epetra_MpiComm &>(E.Comm()).Comm(), &comm));
        n_local                   = E.NumMyRows();
        first_row                 = E.RowMap().MinMyGID64();
        AssertThrow(E.RowMap().MaxMyGID64() - first_row + 1 == n_local,
                    ExcMessage("MUMPS's distributed path needs each process's DoFs to be one contiguous range."));
        AssertThrow(E.NumGlobalRows64() < std::numeric_limits<MUMPS_INT>::max(),
                    ExcMessage("K has " + std::to_string(E.NumGlobalRows64()) +
                               " rows, more than MUMPS's 32-bit indices address."));
        dealii::Timer timer;
        start_instance(int(E.NumGlobalRows64()));
        copy_upper_triangle(E);
        // The pivot order is ours (ICNTL(7) = 1), read by the host in a sequential analysis.
        pivot_order         = node_graph_pivot_order(E, first_row, comm);
        mumps.perm_in       = pivot_order.data();
        mumps.icntl[7 - 1]  = 1;
        mumps.icntl[28 - 1] = 1;
        run(1, "analysis");
        std::vector<MUMPS_INT>().swap(pivot_order);
        stats.analyze_seconds = timer.wall_time();
        // INFOG(7): the ordering MUMPS used; 1 is ours. Said, should MUMPS ever put its own in place.
        const int ordering = mumps.infog[7 - 1];
        stats.method       = std::string("mumps-cholesky (MUMPS, symmetric ") +
                       (positive_definite ? "positive definite" : "indefinite, with pivoting") + ", " +
                       (ordering == 1 ? "METIS node ordering" : "MUMPS's ordering " + std::to_string(ordering)) +
                       ", distributed)";
      }

      ~MumpsCholesky() override
      {
        mumps.job = -2; // JOB_END: frees MUMPS's data (and removes its files; private_directory then goes)
        dmumps_c(&mumps);
        MPI_Comm_free(&comm);
      }

      // MUMPS's INFOG(16) after the analysis: its in-core data for the factorization, in MB, on the
      // process that needs most; INFOG(26) the same for the factor on disk (the fronts being worked
      // on and the stack of their contributions).
      double predicted_in_core_bytes_per_process() const { return 1e6 * double(mumps.infog[16 - 1]); }
      double predicted_out_of_core_bytes_per_process() const { return 1e6 * double(mumps.infog[26 - 1]); }
      // INFOG(3): the factor's values on all processes together, what the files hold out of core.
      double predicted_factor_bytes() const { return 8. * mumps_count(mumps.infog[3 - 1]); }

      // The factor goes to files in directory (ICNTL(22) = 1) instead of memory; checked here, on
      // every process, where a missing directory or a full disk can still be named (MUMPS would
      // stop halfway through the factorization). The room asked for is the whole factor's, as if
      // all processes shared the directory; each process then writes in its own subdirectory
      // (PrivateFactorDirectory). Empty: $MUMPS_OOC_TMPDIR (MUMPS's own variable), else
      // $TMPDIR, else /tmp.
      void store_factor_on_disk(std::string directory)
      {
        for (const char *variable : {"MUMPS_OOC_TMPDIR", "TMPDIR"})
          if (directory.empty() && std::getenv(variable) != nullptr)
            directory = std::getenv(variable);
        if (directory.empty())
          directory = "/tmp";
        std::string                             problem = factor_directory_problem(directory, predicted_factor_bytes());
        std::unique_ptr<PrivateFactorDirectory> own;
        if (problem.empty())
          {
            own     = std::make_unique<PrivateFactorDirectory>(directory);
            problem = own->problem;
            if (problem.empty() && own->path.size() >= sizeof(mumps.ooc_tmpdir))
              problem = "is too long: MUMPS takes " + std::to_string(sizeof(mumps.ooc_tmpdir) - 1) +
                        " characters for its files' directory " + own->path;
          }
        const bool fine_everywhere = dealii::Utilities::MPI::max(int(!problem.empty()), comm) == 0;
        AssertThrow(fine_everywhere,
                    ExcMessage("'Modes/Factor directory' (" + directory + ") " +
                               (problem.empty() ? "failed on another process" : problem) +
                               ": MUMPS cannot keep its factor there (Factor storage = disk, or auto out of core)."));
        private_directory = std::move(own);
        std::strncpy(mumps.ooc_tmpdir, private_directory->path.c_str(), sizeof(mumps.ooc_tmpdir) - 1);
        mumps.icntl[22 - 1] = 1;
        stats.method.insert(stats.method.rfind(')'), ", factor on disk in " + directory);
      }

      // MUMPS works in the space its analysis estimated plus ICNTL(14) per cent; its dynamic
      // scheduling between processes can need more (INFOG(1) = -9 on the test scene's 4,686 DoFs at
      // np = 2, for some of gmsh's meshes): a workspace shortfall is factorized anew with the
      // relaxation doubled (up to 640 %), as MUMPS's manual advises.
      void factorize()
      {
        dealii::Timer timer;
        int           relaxed_to = 0; // the ICNTL(14) of the last attempt, once it had to be raised
        mumps.a_loc   = matrix_values.data(); // the values only now: the analysis orders by the pattern
        for (;;)
          {
            mumps.job = 2;
            dmumps_c(&mumps);
            const int status = mumps.infog[1 - 1];
            if (status >= 0)
              break;
            const int  relaxation      = mumps.icntl[14 - 1];
            const bool workspace_short = status == -8 || status == -9 || status == -11 || status == -12 ||
                                         status == -14 || status == -15 || status == -17 || status == -20;
            relaxed_to = std::max({40, 2 * relaxation, 2 * relaxed_to});
            AssertThrow(workspace_short && relaxed_to <= 640,
                        ExcMessage("MUMPS's factorization of K failed: INFOG(1) = " + std::to_string(status) +
                                   ", INFOG(2) = " + std::to_string(mumps.infog[2 - 1]) +
                                   ", workspace relaxation ICNTL(14) = " + std::to_string(relaxation) +
                                   " % (MUMPS's manual, section 'Error diagnostics'; -10: K is singular, is the part "
                                   "held? -13: out of memory)."));
            mumps.icntl[14 - 1] = relaxed_to;
          }
        if (relaxed_to > 0)
          stats.method += " [workspace relaxed to " + std::to_string(relaxed_to) + " %]";
        stats.factorize_seconds = timer.wall_time();
        // The factor is MUMPS's own now: the triplets are not read again (no iterative refinement).
        std::vector<MUMPS_INT>().swap(matrix_rows);
        std::vector<MUMPS_INT>().swap(matrix_columns);
        std::vector<double>().swap(matrix_values);
        stats.factor_nonzeros = mumps_count(mumps.infog[29 - 1]);
        stats.factor_flops    = mumps.rinfog[3 - 1]; // the elimination's operations, all processes
        if (!positive_definite)
          negative = mumps.infog[12 - 1]; // with SYM = 2: the negative pivots of D
        solution_rows.resize(mumps.info[23 - 1]); // INFO(23): the solution's rows on this process
        for (int i = 0; i < n_local; ++i)
          owned_rows.push_back(MUMPS_INT(first_row + i + 1));
      }

      void solve_block(double *columns, const int count) const override
      {
        dealii::Timer timer;
        const bool    loads_finite = all_finite(columns, std::size_t(n_local) * count);
        solution.resize(solution_rows.size() * count);
        mumps.nrhs = count;
        if (gather_if_sparse(columns, count))
          {
            // Centralised sparse right-hand sides (ICNTL(20) = 1): MUMPS prunes the forward
            // elimination to the paths of their nonzeros in the elimination tree.
            mumps.icntl[20 - 1] = 1;
            mumps.nz_rhs        = MUMPS_INT(sparse_values.size());
            mumps.rhs_sparse    = sparse_values.data();
            mumps.irhs_sparse   = sparse_rows.data();
            mumps.irhs_ptr      = sparse_starts.data();
          }
        else
          {
            mumps.icntl[20 - 1] = 10;
            mumps.nloc_rhs      = n_local;
            mumps.lrhs_loc      = n_local;
            mumps.irhs_loc      = const_cast<MUMPS_INT *>(owned_rows.data()); // read only
            mumps.rhs_loc       = columns;
          }
        mumps.lsol_loc = MUMPS_INT(solution_rows.size());
        mumps.sol_loc  = solution.data();
        mumps.isol_loc = solution_rows.data();
        // MUMPS's blocking of right-hand sides (ICNTL(27)) is 32 columns by default: a static
        // correction block of 48 would read the factor twice. The whole block in one pass: the
        // default scene's static correction at np = 2 took 8 % less time (docs/cluster.md).
        mumps.icntl[27 - 1] = count;
        run(3, "solve");
        move_solution_to_owners(columns, count);
        expect_finite_solution(columns, std::size_t(n_local) * count, loads_finite, comm);
        stats.solve_seconds += timer.wall_time();
        stats.n_solved_vectors += count;
      }

      void vmult(Vector &dst, const Vector &src) const override
      {
        dst = src;
        solve_block(dst.trilinos_vector()[0], 1);
      }

      // One block of all columns (MUMPS reads its factor once for them).
      void solve_columns(std::vector<Vector> &columns) const override
      {
        const std::size_t rows = n_local;
        block.resize(rows * columns.size());
        for (std::size_t c = 0; c < columns.size(); ++c)
          std::copy(columns[c].trilinos_vector()[0], columns[c].trilinos_vector()[0] + rows, block.data() + c * rows);
        solve_block(block.data(), int(columns.size()));
        for (std::size_t c = 0; c < columns.size(); ++c)
          std::copy(block.data() + c * rows, block.data() + (c + 1) * rows, columns[c].trilinos_vector()[0]);
      }

      long negative_eigenvalues() const override { return negative; }

    private:
      // JOB = -1 on every process of comm (the host works too, PAR = 1); SYM = 1 (L D L^T without
      // pivoting) for a positive definite matrix, else 2. MUMPS's own printing off: its status is
      // read from INFOG and said in our messages.
      void start_instance(const int n_global)
      {
        mumps.job          = -1;
        mumps.par          = 1;
        mumps.sym          = positive_definite ? 1 : 2;
        mumps.comm_fortran = MUMPS_INT(MPI_Comm_c2f(comm));
        dmumps_c(&mumps);
        AssertThrow(mumps.infog[1 - 1] >= 0, ExcMessage("MUMPS could not start: INFOG(1) = " +
                                                         std::to_string(mumps.infog[1 - 1]) + "."));
        mumps.icntl[1 - 1]  = -1; // error messages
        mumps.icntl[2 - 1]  = -1; // diagnostics
        mumps.icntl[3 - 1]  = -1; // global information
        mumps.icntl[4 - 1]  = 0;
        mumps.icntl[5 - 1]  = 0;  // assembled matrix
        mumps.icntl[18 - 1] = 3;  // distributed by the caller, as triplets
        mumps.icntl[20 - 1] = 10; // distributed dense right-hand sides
        mumps.icntl[21 - 1] = 1;  // distributed solution
        mumps.n             = n_global;
      }

      // A's entries on and above the diagonal, 1-based global indices: MUMPS's symmetric modes sum
      // whatever they get of both triangles, so each entry is given once.
      void copy_upper_triangle(const Epetra_CrsMatrix &E)
      {
        for (int i = 0; i < n_local; ++i)
          {
            int     count;
            double *values;
            int    *indices;
            E.ExtractMyRowView(i, count, values, indices);
            const long long row = first_row + i;
            for (int k = 0; k < count; ++k)
              if (const long long column = E.ColMap().GID64(indices[k]); column >= row)
                {
                  matrix_rows.push_back(MUMPS_INT(row + 1));
                  matrix_columns.push_back(MUMPS_INT(column + 1));
                  matrix_values.push_back(values[k]);
                }
          }
        mumps.nnz_loc = MUMPS_INT8(matrix_values.size());
        mumps.irn_loc = matrix_rows.data();
        mumps.jcn_loc = matrix_columns.data();
      }

      void run(const int job, const char *phase) const
      {
        mumps.job = job;
        dmumps_c(&mumps);
        AssertThrow(mumps.infog[1 - 1] >= 0,
                    ExcMessage(std::string("MUMPS's ") + phase + " of K failed: INFOG(1) = " +
                               std::to_string(mumps.infog[1 - 1]) + ", INFOG(2) = " +
                               std::to_string(mumps.infog[2 - 1]) + " (MUMPS's manual, section 'Error diagnostics')."));
      }

      // Right-hand sides whose nonzeros are at most 1 % of their entries (the static correction's
      // patch loads: tens of rows in 10^5) are gathered on the host in MUMPS's compressed-column
      // form (sparse_*); returns whether they were (collective: every process decides alike).
      bool gather_if_sparse(const double *columns, const int count) const
      {
        std::vector<int> per_column(count, 0);
        for (int c = 0; c < count; ++c)
          per_column[c] = int(std::count_if(columns + std::size_t(c) * n_local, columns + std::size_t(c + 1) * n_local,
                                            [](const double v) { return v != 0.; }));
        long long nonzeros = std::accumulate(per_column.begin(), per_column.end(), 0LL);
        AssertThrowMPI(MPI_Allreduce(MPI_IN_PLACE, &nonzeros, 1, MPI_LONG_LONG, MPI_SUM, comm));
        if (nonzeros == 0 || nonzeros > 0.01 * double(mumps.n) * count)
          return false;
        std::vector<int>    own_rows;
        std::vector<double> own_values;
        for (int c = 0; c < count; ++c)
          for (int i = 0; i < n_local; ++i)
            if (const double v = columns[std::size_t(c) * n_local + i]; v != 0.)
              {
                own_rows.push_back(int(first_row + i + 1));
                own_values.push_back(v);
              }
        const std::vector<int> counts = gather_on_host(per_column, comm), rows = gather_on_host(own_rows, comm);
        const std::vector<double> values = gather_on_host(own_values, comm);
        if (dealii::Utilities::MPI::this_mpi_process(comm) != 0)
          return true;
        // counts: process-major (each process's count per column); rows and values likewise.
        const int n_processes = int(counts.size()) / count;
        std::vector<std::size_t> offset(n_processes, 0); // where each process's entries start
        for (int p = 1; p < n_processes; ++p)
          offset[p] = offset[p - 1] + std::accumulate(&counts[(p - 1) * count], &counts[p * count], std::size_t(0));
        sparse_starts.assign(1, 1);
        sparse_rows.clear();
        sparse_values.clear();
        for (int c = 0; c < count; ++c)
          {
            for (int p = 0; p < n_processes; ++p)
              {
                const int k = counts[p * count + c];
                sparse_rows.insert(sparse_rows.end(), &rows[offset[p]], &rows[offset[p]] + k);
                sparse_values.insert(sparse_values.end(), &values[offset[p]], &values[offset[p]] + k);
                offset[p] += k;
              }
            sparse_starts.push_back(MUMPS_INT(sparse_rows.size() + 1));
          }
        return true;
      }

      // MUMPS returns each process the solution rows of the pivots it eliminated (ISOL_loc), in its
      // own order: they go to the processes that own them, into columns (n_local rows each). The
      // plan follows ISOL_loc, which stays the same from one solve to the next with one factor:
      // rebuilt only when any process sees it change (one small reduction per solve).
      void move_solution_to_owners(double *columns, const int count) const
      {
        int changed = solution_rows != exchange.planned_rows;
        AssertThrowMPI(MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_LOR, comm));
        if (changed)
          plan_exchange();
        const auto &x = exchange;
        const int   n_processes = int(x.send_counts.size());
        send.resize(x.send_rows.size() * count);
        receive.resize(x.receive_rows.size() * count);
        std::vector<int> send_counts(n_processes), send_offsets(n_processes), receive_counts(n_processes),
          receive_offsets(n_processes);
        const std::size_t lsol = solution_rows.size();
        for (int p = 0; p < n_processes; ++p)
          {
            send_counts[p]     = x.send_counts[p] * count;
            send_offsets[p]    = x.send_offsets[p] * count;
            receive_counts[p]  = x.receive_counts[p] * count;
            receive_offsets[p] = x.receive_offsets[p] * count;
            double *out        = send.data() + send_offsets[p];
            for (int c = 0; c < count; ++c)
              for (int k = 0; k < x.send_counts[p]; ++k)
                *out++ = solution[c * lsol + x.send_rows[x.send_offsets[p] + k]];
          }
        AssertThrowMPI(MPI_Alltoallv(send.data(), send_counts.data(), send_offsets.data(), MPI_DOUBLE,
                                     receive.data(), receive_counts.data(), receive_offsets.data(), MPI_DOUBLE, comm));
        for (int p = 0; p < n_processes; ++p)
          {
            const double *in = receive.data() + receive_offsets[p];
            for (int c = 0; c < count; ++c)
              for (int k = 0; k < x.receive_counts[p]; ++k)
                columns[std::size_t(c) * n_local + x.receive_rows[x.receive_offsets[p] + k]] = *in++;
          }
      }

      // Who owns each of MUMPS's solution rows (the processes' contiguous ranges, gathered), and
      // which local rows each process receives (the global rows, sent once).
      void plan_exchange() const
      {
        const int            n_processes = dealii::Utilities::MPI::n_mpi_processes(comm);
        std::vector<long long> starts(n_processes + 1);
        AssertThrowMPI(MPI_Allgather(&first_row, 1, MPI_LONG_LONG, starts.data(), 1, MPI_LONG_LONG, comm));
        starts[n_processes] = mumps.n;
        const auto owner    = [&](const long long row) {
          return int(std::upper_bound(starts.begin(), starts.end(), row) - starts.begin()) - 1;
        };
        auto &x = exchange;
        x.send_counts.assign(n_processes, 0);
        for (const MUMPS_INT row : solution_rows)
          ++x.send_counts[owner(row - 1)];
        x.send_offsets.assign(n_processes, 0);
        for (int p = 1; p < n_processes; ++p)
          x.send_offsets[p] = x.send_offsets[p - 1] + x.send_counts[p - 1];
        x.send_rows.resize(solution_rows.size());
        std::vector<int>       filled = x.send_offsets;
        std::vector<MUMPS_INT> global_rows(solution_rows.size());
        for (std::size_t i = 0; i < solution_rows.size(); ++i)
          {
            const int slot    = filled[owner(solution_rows[i] - 1)]++;
            x.send_rows[slot] = int(i);
            global_rows[slot] = solution_rows[i];
          }
        x.receive_counts.resize(n_processes);
        AssertThrowMPI(MPI_Alltoall(x.send_counts.data(), 1, MPI_INT, x.receive_counts.data(), 1, MPI_INT, comm));
        x.receive_offsets.assign(n_processes, 0);
        for (int p = 1; p < n_processes; ++p)
          x.receive_offsets[p] = x.receive_offsets[p - 1] + x.receive_counts[p - 1];
        const int received = x.receive_offsets.back() + x.receive_counts.back();
        AssertThrow(received == n_local, ExcMessage("MUMPS's solution covers " + std::to_string(received) + " of the " +
                                                    std::to_string(n_local) + " rows this process owns."));
        std::vector<MUMPS_INT> receive_global(received);
        AssertThrowMPI(MPI_Alltoallv(global_rows.data(), x.send_counts.data(), x.send_offsets.data(), MPI_INT,
                                     receive_global.data(), x.receive_counts.data(), x.receive_offsets.data(), MPI_INT,
                                     comm));
        x.receive_rows.resize(received);
        for (int k = 0; k < received; ++k)
          x.receive_rows[k] = int(receive_global[k] - 1 - first_row);
        x.planned_rows = solution_rows;
      }

      // Each process's part of the move from MUMPS's solution rows to their owners, in rows (the
      // counts of a solve are these times its columns).
      struct Exchange
      {
        std::vector<int>       send_counts, send_offsets, receive_counts, receive_offsets;
        std::vector<int>       send_rows;    // indices into MUMPS's local solution, by destination
        std::vector<int>       receive_rows; // local rows, by source
        std::vector<MUMPS_INT> planned_rows; // the ISOL_loc this plan was made for
      };

      const bool               positive_definite;
      FactorizationStatistics &stats;
      MPI_Comm                 comm      = MPI_COMM_NULL;
      int                      n_local   = 0;
      long long                first_row = 0;
      long                     negative  = -1; // INFOG(12), read only in the indefinite mode
      mutable DMUMPS_STRUC_C   mumps     = {};
      std::vector<MUMPS_INT>   matrix_rows, matrix_columns; // the upper triangle, until factorized
      std::vector<double>      matrix_values;
      std::vector<MUMPS_INT>   pivot_order;                 // PERM_IN, on the host, until analyzed
      std::vector<MUMPS_INT>   owned_rows;                  // 1-based: the right-hand sides' rows
      mutable std::vector<MUMPS_INT> solution_rows;         // ISOL_loc
      mutable std::vector<double>    solution, send, receive, block;
      mutable std::vector<MUMPS_INT> sparse_rows, sparse_starts; // the host's sparse right-hand sides
      mutable std::vector<double>    sparse_values;
      mutable Exchange               exchange;
      std::unique_ptr<PrivateFactorDirectory> private_directory; // out of core: this process's factor files
    };
  } // namespace

  std::unique_ptr<DistributedInverse>
  make_mumps_inverse(const dealii::TrilinosWrappers::SparseMatrix &A, const DistributedFactorizationKind kind,
                     const bool positive_definite, const std::string &directory, FactorizationStatistics &stats,
                     const std::function<solver_choice::Placement(const solver_choice::MumpsPrediction &)> &place)
  {
    using solver_choice::Placement;
    solver_choice::MumpsPrediction prediction;
    if (kind == DistributedFactorizationKind::mumps_lu)
      {
        const Placement placement = place(prediction);
        Assert(placement == Placement::memory, ExcMessage("MUMPS's LU through Amesos keeps its factor in memory."));
        (void)placement;
        return std::make_unique<AmesosMumpsLU>(A, stats);
      }
    auto inverse                 = std::make_unique<MumpsCholesky>(A, positive_definite, stats);
    prediction.in_core_bytes     = inverse->predicted_in_core_bytes_per_process();
    prediction.out_of_core_bytes = inverse->predicted_out_of_core_bytes_per_process();
    prediction.factor_bytes      = inverse->predicted_factor_bytes();
    const Placement placement    = place(prediction);
    if (placement == Placement::none)
      return nullptr;
    if (placement == Placement::disk)
      inverse->store_factor_on_disk(directory);
    inverse->factorize();
    return inverse;
  }
} // namespace modal_haptics
