#include "mumps_inverse.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_solver.h>

#include <Epetra_CrsMatrix.h>
#include <Epetra_FEVector.h>
#include <Epetra_MpiComm.h>
#include <petscmat.h>

#include <algorithm>
#include <cmath>
#include <limits>
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
    void check(const PetscErrorCode code, const char *call)
    {
      AssertThrow(code == 0, ExcMessage(std::string("PETSc's ") + call + " failed (error " + std::to_string(code) +
                                        ") while factorizing K with MUMPS."));
    }

    // A NaN or infinity out of a solve would otherwise surface far away (PARPACK's "info -9999"
    // after DLASCL complaints): said here, where it appears, with whether the right-hand side
    // already had one. One pass over the local entries, small beside the solve.
    bool all_finite(const double *values, const std::size_t count)
    {
      return std::all_of(values, values + count, [](const double v) { return std::isfinite(v); });
    }

    void expect_finite_solution(const Vector &solution, const double *right_hand_side)
    {
      const auto count = solution.locally_owned_size();
      if (all_finite(solution.trilinos_vector()[0], count))
        return;
      const auto process = dealii::Utilities::MPI::this_mpi_process(solution.get_mpi_communicator());
      AssertThrow(false, ExcMessage("MUMPS's solve returned a non-finite value on process " + std::to_string(process) +
                                    (all_finite(right_hand_side, count) ? " from a finite right-hand side"
                                                                         : ", whose right-hand side was not finite either") +
                                    "."));
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
        dealii::Timer timer;
        solver.initialize(A);
        stats.factorize_seconds = timer.wall_time();
      }

      void vmult(Vector &dst, const Vector &src) const override
      {
        dealii::Timer timer;
        solver.solve(dst, src);
        expect_finite_solution(dst, src.trilinos_vector()[0]);
        stats.solve_seconds += timer.wall_time();
        ++stats.n_solved_vectors;
      }

    private:
      mutable dealii::SolverControl                  control;
      mutable dealii::TrilinosWrappers::SolverDirect solver;
      FactorizationStatistics                       &stats;
    };

    // PETSc's MUMPS in its symmetric mode. A is copied row by row into a PETSc matrix with the
    // same contiguous row ownership (deal.II's owned DoFs); the solves wrap the Trilinos vectors'
    // local arrays, copying nothing.
    class PetscMumpsCholesky : public DistributedInverse
    {
    public:
      // Copies A and runs MUMPS's analysis (ordering, symbolic factorization): what the factor will
      // need is known from here on (predicted_bytes_per_process), and factorize() computes it.
      PetscMumpsCholesky(const dealii::TrilinosWrappers::SparseMatrix &A, const bool positive_definite,
                         FactorizationStatistics &stats)
        : positive_definite(positive_definite)
        , stats(stats)
      {
        stats.method = std::string("mumps-cholesky (PETSc's MUMPS, symmetric ") +
                       (positive_definite ? "positive definite" : "indefinite, with pivoting") + ", distributed)";
        const Epetra_CrsMatrix &E    = A.trilinos_matrix();
        comm                         = dynamic_cast<const Epetra_MpiComm &>(E.Comm()).Comm();
        n_local                      = E.NumMyRows();
        dealii::Timer timer;
        copy_matrix(E, comm, positive_definite);
        check(MatFactorInfoInitialize(&info), "MatFactorInfoInitialize");
        analyze(-1);
        stats.analyze_seconds = timer.wall_time();
      }

      // MUMPS's INFOG(16) after the analysis: its in-core data for the factorization, in MB, on the
      // process that needs most.
      double predicted_bytes_per_process() const
      {
        PetscInt megabytes = 0;
        check(MatMumpsGetInfog(factor, 16, &megabytes), "MatMumpsGetInfog");
        return 1e6 * double(megabytes);
      }

      // MUMPS works in the space its analysis estimated plus ICNTL(14) per cent; its dynamic
      // scheduling between processes can need more (INFOG(1) = -9 on the test scene's 4,686 DoFs at
      // np = 2, for some of gmsh's meshes). PETSc then only marks the factor as failed, and every
      // solve with it returns infinities: the status is checked, and a workspace shortfall is
      // factorized anew with the relaxation doubled (up to 640 %).
      void factorize()
      {
        dealii::Timer timer;
        PetscInt      relaxed_to = 0; // the ICNTL(14) of the last analysis, once it had to be raised
        for (;;)
          {
            check(MatCholeskyFactorNumeric(factor, matrix, &info), "MatCholeskyFactorNumeric");
            PetscInt status = 0, detail = 0, relaxation = 0;
            check(MatMumpsGetInfog(factor, 1, &status), "MatMumpsGetInfog");
            if (status >= 0)
              break;
            check(MatMumpsGetInfog(factor, 2, &detail), "MatMumpsGetInfog");
            check(MatMumpsGetIcntl(factor, 14, &relaxation), "MatMumpsGetIcntl");
            const bool workspace_short = status == -8 || status == -9 || status == -11 || status == -12 ||
                                         status == -14 || status == -15 || status == -17 || status == -20;
            relaxed_to = std::max<PetscInt>({40, 2 * relaxation, 2 * relaxed_to});
            AssertThrow(workspace_short && relaxed_to <= 640,
                        ExcMessage("MUMPS's factorization of K failed: INFOG(1) = " + std::to_string(status) +
                                   ", INFOG(2) = " + std::to_string(detail) + ", workspace relaxation ICNTL(14) = " +
                                   std::to_string(relaxation) + " % (MUMPS's manual, section 'Error diagnostics'; " +
                                   "-10: K is singular, is the part held? -13: out of memory)."));
            analyze(relaxed_to);
          }
        if (relaxed_to > 0)
          stats.method += " [workspace relaxed to " + std::to_string(relaxed_to) + " %]";
        stats.factorize_seconds = timer.wall_time();
        PetscInt entries = 0; // INFOG(29): the factor's entries, in millions when negative
        check(MatMumpsGetInfog(factor, 29, &entries), "MatMumpsGetInfog");
        if (!positive_definite)
          {
            PetscInt negative_pivots = 0; // INFOG(12) with SYM = 2: the negative pivots of D
            check(MatMumpsGetInfog(factor, 12, &negative_pivots), "MatMumpsGetInfog");
            negative = negative_pivots;
          }
        stats.factor_nonzeros = entries >= 0 ? double(entries) : -1e6 * double(entries);
        check(VecCreateMPIWithArray(comm, 1, n_local, PETSC_DECIDE, nullptr, &b), "VecCreateMPIWithArray");
        check(VecCreateMPIWithArray(comm, 1, n_local, PETSC_DECIDE, nullptr, &x), "VecCreateMPIWithArray");
      }

      ~PetscMumpsCholesky() override
      {
        VecDestroy(&x);
        VecDestroy(&b);
        MatDestroy(&factor);
        MatDestroy(&matrix);
      }

      void vmult(Vector &dst, const Vector &src) const override
      {
        dealii::Timer timer;
        check(VecPlaceArray(b, src.trilinos_vector()[0]), "VecPlaceArray");
        check(VecPlaceArray(x, dst.trilinos_vector()[0]), "VecPlaceArray");
        check(MatSolve(factor, b, x), "MatSolve");
        check(VecResetArray(x), "VecResetArray");
        check(VecResetArray(b), "VecResetArray");
        expect_finite_solution(dst, src.trilinos_vector()[0]);
        stats.solve_seconds += timer.wall_time();
        ++stats.n_solved_vectors;
      }

      void solve_columns(std::vector<Vector> &columns) const override
      {
        if (columns.empty())
          return;
        dealii::Timer  timer;
        const PetscInt n_columns = PetscInt(columns.size());
        Mat            B, X;
        check(MatCreateDense(comm, n_local, PETSC_DECIDE, PETSC_DETERMINE, n_columns, nullptr, &B), "MatCreateDense");
        check(MatCreateDense(comm, n_local, PETSC_DECIDE, PETSC_DETERMINE, n_columns, nullptr, &X), "MatCreateDense");
        PetscInt     ld;
        PetscScalar *values;
        check(MatDenseGetLDA(B, &ld), "MatDenseGetLDA");
        check(MatDenseGetArray(B, &values), "MatDenseGetArray");
        for (PetscInt c = 0; c < n_columns; ++c)
          std::copy(columns[c].trilinos_vector()[0], columns[c].trilinos_vector()[0] + n_local, values + c * ld);
        check(MatDenseRestoreArray(B, &values), "MatDenseRestoreArray");
        // MUMPS's blocking of right-hand sides (ICNTL(27)) is 32 columns by default: a static
        // correction block of 48 would read the factor twice. The whole block in one pass: the
        // default scene's static correction at np = 2 took 8 % less time (docs/cluster.md).
        check(MatMumpsSetIcntl(factor, 27, n_columns), "MatMumpsSetIcntl");
        check(MatMatSolve(factor, B, X), "MatMatSolve");
        PetscInt           x_ld, b_ld;
        const PetscScalar *solutions, *loads;
        check(MatDenseGetLDA(X, &x_ld), "MatDenseGetLDA");
        check(MatDenseGetLDA(B, &b_ld), "MatDenseGetLDA");
        check(MatDenseGetArrayRead(X, &solutions), "MatDenseGetArrayRead");
        check(MatDenseGetArrayRead(B, &loads), "MatDenseGetArrayRead");
        // Written over the columns (B keeps their right-hand sides): a new vector per column would
        // build a new Epetra map each time.
        for (PetscInt c = 0; c < n_columns; ++c)
          {
            std::copy(solutions + c * x_ld, solutions + c * x_ld + n_local, columns[c].trilinos_vector()[0]);
            expect_finite_solution(columns[c], loads + c * b_ld);
          }
        check(MatDenseRestoreArrayRead(B, &loads), "MatDenseRestoreArrayRead");
        check(MatDenseRestoreArrayRead(X, &solutions), "MatDenseRestoreArrayRead");
        MatDestroy(&X);
        MatDestroy(&B);
        stats.solve_seconds += timer.wall_time();
        stats.n_solved_vectors += columns.size();
      }

      long negative_eigenvalues() const override { return negative; }

    private:
      // A new MUMPS factor of the matrix and its analysis; relaxation >= 0 sets ICNTL(14), the per
      // cent added to the analysis's workspace estimate (else MUMPS's default).
      void analyze(const PetscInt relaxation)
      {
        MatDestroy(&factor);
        check(MatGetFactor(matrix, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &factor), "MatGetFactor");
        if (relaxation >= 0)
          check(MatMumpsSetIcntl(factor, 14, relaxation), "MatMumpsSetIcntl");
        check(MatCholeskyFactorSymbolic(factor, matrix, nullptr, &info), "MatCholeskyFactorSymbolic");
        PetscInt status = 0;
        check(MatMumpsGetInfog(factor, 1, &status), "MatMumpsGetInfog");
        AssertThrow(status >= 0, ExcMessage("MUMPS's analysis of K failed: INFOG(1) = " + std::to_string(status) +
                                            " (MUMPS's manual, section 'Error diagnostics')."));
      }

      // A's rows into an MPI AIJ matrix, preallocated from their counts in and off the diagonal
      // block; marked symmetric (and positive definite) so MUMPS runs with SYM = 2 (or 1).
      void copy_matrix(const Epetra_CrsMatrix &E, const MPI_Comm comm, const bool positive_definite)
      {
        const auto     &rows = E.RowMap(), &columns = E.ColMap();
        const long long first = rows.MinMyGID64(), last = rows.MaxMyGID64();
        AssertThrow(last - first + 1 == n_local,
                    ExcMessage("MUMPS through PETSc needs each process's DoFs to be one contiguous range."));
        std::vector<PetscInt> in_block(n_local, 0), off_block(n_local, 0);
        for (int i = 0; i < n_local; ++i)
          {
            int     count;
            double *values;
            int    *indices;
            E.ExtractMyRowView(i, count, values, indices);
            for (int k = 0; k < count; ++k)
              {
                const long long column = columns.GID64(indices[k]);
                ++(column >= first && column <= last ? in_block[i] : off_block[i]);
              }
          }
        check(MatCreateAIJ(comm, n_local, n_local, PETSC_DETERMINE, PETSC_DETERMINE, 0, in_block.data(), 0,
                           off_block.data(), &matrix),
              "MatCreateAIJ");
        PetscInt own_first, own_end;
        check(MatGetOwnershipRange(matrix, &own_first, &own_end), "MatGetOwnershipRange");
        AssertThrow(own_first == first, ExcMessage("PETSc's row ownership differs from deal.II's owned DoFs."));
        std::vector<PetscInt> global_columns;
        for (int i = 0; i < n_local; ++i)
          {
            int     count;
            double *values;
            int    *indices;
            E.ExtractMyRowView(i, count, values, indices);
            global_columns.resize(count);
            for (int k = 0; k < count; ++k)
              global_columns[k] = PetscInt(columns.GID64(indices[k]));
            const PetscInt row = PetscInt(first + i);
            check(MatSetValues(matrix, 1, &row, count, global_columns.data(), values, INSERT_VALUES), "MatSetValues");
          }
        check(MatAssemblyBegin(matrix, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
        check(MatAssemblyEnd(matrix, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
        check(MatSetOption(matrix, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
        if (positive_definite)
          check(MatSetOption(matrix, MAT_SPD, PETSC_TRUE), "MatSetOption");
      }

      const bool               positive_definite;
      MatFactorInfo            info;
      MPI_Comm                 comm     = MPI_COMM_NULL;
      long                     negative = -1; // INFOG(12), read only in the indefinite mode
      int                      n_local = 0;
      Mat                      matrix  = nullptr, factor = nullptr;
      Vec                      b = nullptr, x = nullptr;
      FactorizationStatistics &stats;
    };
  } // namespace

  std::unique_ptr<DistributedInverse> make_mumps_inverse_within(const dealii::TrilinosWrappers::SparseMatrix &A,
                                                                const DistributedFactorizationKind kind,
                                                                const bool positive_definite,
                                                                FactorizationStatistics &stats,
                                                                const double max_bytes_per_process,
                                                                double &predicted_bytes_per_process)
  {
    predicted_bytes_per_process = -1.;
    if (kind == DistributedFactorizationKind::mumps_lu)
      return std::make_unique<AmesosMumpsLU>(A, stats);
    auto inverse = std::make_unique<PetscMumpsCholesky>(A, positive_definite, stats);
    predicted_bytes_per_process = inverse->predicted_bytes_per_process();
    if (predicted_bytes_per_process > max_bytes_per_process)
      return nullptr;
    inverse->factorize();
    return inverse;
  }

  std::unique_ptr<DistributedInverse> make_mumps_inverse(const dealii::TrilinosWrappers::SparseMatrix &A,
                                                         const DistributedFactorizationKind kind,
                                                         const bool positive_definite, FactorizationStatistics &stats)
  {
    double predicted = 0.;
    return make_mumps_inverse_within(A, kind, positive_definite, stats, std::numeric_limits<double>::infinity(),
                                     predicted);
  }
} // namespace modal_haptics
