// The SLEPc peer of the eigensolver benchmark: Krylov-Schur, shift-invert at 0 with a MUMPS Cholesky,
// relative convergence test, on K and M exported by modal-precompute (binary CSR, see README.md).
// Runs on any number of MPI ranks: every rank reads the file and keeps its block of rows.
//
//   mpirun -np N bench-slepc-peer K.csr M.csr NEV [TOL [PETSc/SLEPc options]]
// prints one line: ranks, n, nev, converged, seconds, first and last eigenvalue.
#include "csr_file.h"

#include <slepceps.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace
{
  using modal_haptics_bench::Csr;

  Mat to_petsc(const Csr &m)
  {
    // Contiguous blocks of rows, as PETSc would split them; exact preallocation.
    PetscInt local = PETSC_DECIDE, global = m.n, last = 0;
    PetscSplitOwnership(PETSC_COMM_WORLD, &local, &global);
    MPI_Scan(&local, &last, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD);
    const PetscInt first = last - local;
    std::vector<PetscInt> diagonal(local), off_diagonal(local);
    for (PetscInt row = first; row < last; ++row)
      for (auto k = m.row_start[row]; k < m.row_start[row + 1]; ++k)
        (m.columns[k] >= first && m.columns[k] < last ? diagonal : off_diagonal)[row - first]++;
    Mat A;
    MatCreateAIJ(PETSC_COMM_WORLD, local, local, m.n, m.n, 0, diagonal.data(), 0, off_diagonal.data(), &A);
    std::vector<PetscInt> columns;
    for (PetscInt row = first; row < last; ++row)
      {
        const auto begin = m.row_start[row], count = m.row_start[row + 1] - begin;
        columns.assign(m.columns.begin() + begin, m.columns.begin() + begin + count);
        MatSetValues(A, 1, &row, count, columns.data(), m.values.data() + begin, INSERT_VALUES);
      }
    MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
    return A;
  }
} // namespace

int main(int argc, char **argv)
{
  SlepcInitialize(&argc, &argv, nullptr, nullptr);
  if (argc < 4)
    {
      PetscPrintf(PETSC_COMM_WORLD, "usage: bench-slepc-peer K.csr M.csr NEV [TOL]\n");
      SlepcFinalize();
      return 2;
    }
  int ranks;
  MPI_Comm_size(PETSC_COMM_WORLD, &ranks);
  const PetscInt  nev = std::stoi(argv[3]);
  const PetscReal tol = argc > 4 ? std::stod(argv[4]) : 1e-10;
  Mat K, M;
  {
    const Csr k = modal_haptics_bench::read_csr(argv[1]), m = modal_haptics_bench::read_csr(argv[2]);
    K = to_petsc(k);
    M = to_petsc(m);
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  const auto start = std::chrono::steady_clock::now();
  EPS eps;
  ST  st;
  KSP ksp;
  PC  pc;
  EPSCreate(PETSC_COMM_WORLD, &eps);
  EPSSetOperators(eps, K, M);
  EPSSetProblemType(eps, EPS_GHEP);
  EPSSetType(eps, EPSKRYLOVSCHUR);
  EPSSetDimensions(eps, nev, PETSC_DEFAULT, PETSC_DEFAULT);
  EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE);
  EPSSetTarget(eps, 0.);
  EPSSetTolerances(eps, tol, 1000);
  EPSSetConvergenceTest(eps, EPS_CONV_REL);
  EPSGetST(eps, &st);
  STSetType(st, STSINVERT);
  STGetKSP(st, &ksp);
  KSPSetType(ksp, KSPPREONLY);
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCCHOLESKY);
  PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
  // MUMPS sizes its real workspace from the analysis' estimate plus ICNTL(14) percent (default 20).
  // On 2 ranks the numerical pivoting of some runs outgrew it (INFOG(1) = -9, "workspace too
  // small") and the peer failed; 100 % extra (the estimate doubled) unless the command line sets
  // it (-st_mat_mumps_icntl_14 N).
  const char *prefix = nullptr;
  KSPGetOptionsPrefix(ksp, &prefix);
  const std::string icntl14 = std::string("-") + (prefix != nullptr ? prefix : "") + "mat_mumps_icntl_14";
  PetscBool         icntl14_given = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, icntl14.c_str(), &icntl14_given);
  if (!icntl14_given)
    PetscOptionsSetValue(nullptr, icntl14.c_str(), "100");
  EPSSetFromOptions(eps);
  EPSSolve(eps);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Mat      factor;
  PetscInt workspace_percent = -1;
  PCFactorGetMatrix(pc, &factor);
  MatMumpsGetIcntl(factor, 14, &workspace_percent);
  PetscInt converged;
  EPSGetConverged(eps, &converged);
  PetscScalar first = 0., last = 0.;
  if (converged > 0)
    {
      EPSGetEigenvalue(eps, 0, &first, nullptr);
      EPSGetEigenvalue(eps, std::min(converged, nev) - 1, &last, nullptr);
    }
  PetscInt n, unused;
  MatGetSize(K, &n, &unused);
  PetscPrintf(PETSC_COMM_WORLD,
              "slepc ranks=%d n=%d nev=%d converged=%d icntl14=%d seconds=%.3f lambda_first=%.12e lambda_last=%.12e\n",
              ranks, int(n), int(nev), int(converged), int(workspace_percent), seconds, double(first), double(last));
  EPSDestroy(&eps);
  MatDestroy(&K);
  MatDestroy(&M);
  SlepcFinalize();
  return converged >= nev ? 0 : 1;
}
