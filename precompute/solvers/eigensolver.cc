#include "solvers/eigensolver.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/arpack_solver.h> // declares ARPACK's dsaupd_ and dseupd_

#include <algorithm>
#include <cmath>
#include <iostream>

namespace modal_haptics
{
  using dealii::ExcMessage;

  namespace
  {
    std::string arpack_error(const char *routine, const int info)
    {
      std::string hint;
      if (info == 1)
        hint = ": the maximum number of restarts was reached (raise 'Modes/Tolerance')";
      else if (info == -9999)
        hint = ": could not build a Lanczos factorization (is the part clamped?)";
      return std::string("ARPACK's ") + routine + " failed with info = " + std::to_string(info) + hint + ".";
    }

    // One reverse-communication step of mode 3: y = (K - sigma M)^{-1} (M x), where ARPACK may
    // hand us M x already computed, projected onto the complement of the modes earlier runs found.
    void apply_shift_invert(Factorization &inverse, const dealii::SparseMatrix<double> &M,
                            const FoundModes<dealii::Vector<double>> &found, const int ido, const int n,
                            double *workd, const int *ipntr, dealii::Vector<double> &x, dealii::Vector<double> &y)
    {
      double *in  = workd + ipntr[0] - 1;
      double *out = workd + ipntr[1] - 1;
      if (ido == -1)
        {
          std::copy(in, in + n, x.begin());
          M.vmult(y, x);
        }
      else // ido == 1: M x is at ipntr[2]
        std::copy(workd + ipntr[2] - 1, workd + ipntr[2] - 1 + n, y.begin());
      inverse.solve_block(y.data(), 1);
      found.project(y);
      std::copy(y.begin(), y.end(), out);
    }

    // ARPACK's state for a symmetric generalized problem in mode 3 (shift-invert), what dsaupd and
    // dseupd share. Twice the wanted count of Lanczos vectors plus a margin: the usual ARPACK advice,
    // and what converged fastest on our panels (about two Lanczos restarts for 50 modes).
    struct ShiftInvertArpack
    {
      ShiftInvertArpack(const int n, const int nev, const double tolerance)
        : n(n)
        , nev(nev)
        , ncv(std::min(n - 1, std::max(2 * nev + 10, 20)))
        , n_arpack(n)
        , nev_arpack(nev)
        , tol(tolerance)
        , resid(n, 1.)
        , v(std::size_t(n) * ncv)
        , workd(3 * std::size_t(n))
        , workl(std::size_t(ncv) * (ncv + 8))
        , lworkl(workl.size())
        , iparam(11, 0)
        , ipntr(14, 0)
      {
        iparam[0] = 1;     // exact shifts
        iparam[2] = 10000; // maximum restarts
        iparam[6] = 3;     // shift-invert mode
      }

      // One reverse-communication call of dsaupd; what ARPACK asks for next (ido).
      int step()
      {
        dealii::dsaupd_(&ido, bmat, &n_arpack, which, &nev_arpack, &tol, resid.data(), &ncv, v.data(), &n,
                        iparam.data(), ipntr.data(), workd.data(), workl.data(), &lworkl, &info);
        return ido;
      }

      int n, nev, ncv;
      // deal.II declares ARPACK's n and nev as unsigned.
      unsigned int        n_arpack, nev_arpack;
      int                 ido = 0, info = 0;
      char                bmat[2]  = "G";
      char                which[3] = "LM"; // largest of 1/(lambda - sigma): closest to the shift
      double              tol;
      std::vector<double> resid, v, workd, workl;
      int                 lworkl;
      std::vector<int>    iparam, ipntr;
    };

    // The Lanczos iteration: dsaupd until it converges, applying the shift-invert operator (in the
    // complement of the found modes) and M when asked. Counts the operator applications and the
    // restarts in `solution`.
    void run_lanczos(ShiftInvertArpack &arpack, Factorization &inverse, const dealii::SparseMatrix<double> &M,
                     const FoundModes<dealii::Vector<double>> &found, const bool verbose, const dealii::Timer &timer,
                     EigenSolution &solution)
    {
      const int              n = arpack.n;
      dealii::Vector<double> x(n), y(n);
      while (true)
        {
          const int ido = arpack.step();
          if (ido == -1 || ido == 1)
            {
              apply_shift_invert(inverse, M, found, ido, n, arpack.workd.data(), arpack.ipntr.data(), x, y);
              ++solution.n_operator_applications;
              if (verbose && solution.n_operator_applications % 25 == 0)
                std::cout << "[eigensolve]   " << solution.n_operator_applications << " solves, "
                          << timer.wall_time() << " s" << std::endl;
            }
          else if (ido == 2)
            {
              auto &workd = arpack.workd;
              std::copy(workd.begin() + arpack.ipntr[0] - 1, workd.begin() + arpack.ipntr[0] - 1 + n, x.begin());
              M.vmult(y, x);
              std::copy(y.begin(), y.end(), workd.begin() + arpack.ipntr[1] - 1);
            }
          else
            break;
        }
      AssertThrow(arpack.info >= 0, ExcMessage(arpack_error("dsaupd", arpack.info)));
      AssertThrow(arpack.info != 1, ExcMessage(arpack_error("dsaupd", arpack.info)));
      solution.n_restarts += arpack.iparam[2];
    }

    // dseupd: the converged eigenvalues and their vectors (column after column in z), in ARPACK's order.
    void extract_eigenpairs(ShiftInvertArpack &arpack, const double shift, std::vector<double> &lambda,
                            std::vector<double> &z)
    {
      const int           n       = arpack.n;
      int                 rvec    = 1;
      char                howmany = 'A';
      std::vector<int>    select(arpack.ncv, 1);
      double              sigma = shift;
      lambda.assign(arpack.nev, 0.);
      z.assign(std::size_t(n) * arpack.nev, 0.);
      dealii::dseupd_(&rvec, &howmany, select.data(), lambda.data(), z.data(), &arpack.n, &sigma, arpack.bmat,
                      &arpack.n_arpack, arpack.which, &arpack.nev_arpack, &arpack.tol, arpack.resid.data(), &arpack.ncv,
                      arpack.v.data(), &arpack.n, arpack.iparam.data(), arpack.ipntr.data(), arpack.workd.data(),
                      arpack.workl.data(), &arpack.lworkl, &arpack.info);
      AssertThrow(arpack.info == 0, ExcMessage(arpack_error("dseupd", arpack.info)));
      const int n_converged = arpack.iparam[4];
      AssertThrow(n_converged >= arpack.nev,
                  ExcMessage("ARPACK converged only " + std::to_string(n_converged) + " of " +
                             std::to_string(arpack.nev) + " modes."));
    }
  } // namespace

  // Runs of ARPACK until the cut-off decides the count (CutOffStop::next_batch), each for the next
  // modes in the M-orthogonal complement of the earlier runs' (FoundModes). Why the runs may stop
  // there is CutOffStop's argument (eigensolver.h): with the shift below the first mode, a run's nev
  // modes are the lowest nev of its complement, so every mode no run has found lies above all the
  // found ones. No Sylvester count checks it: the inertia of K - cut-off M would take a second
  // factorization. A later run
  // starts from ARPACK's random vector put into the range of the projected operator (dsaupd applies
  // OP to it for bmat = 'G'): what it reuses of the earlier runs is their converged modes, through
  // the projection, which ARPACK cannot be given as locked vectors.
  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &inverse,
                                   const double                        shift,
                                   const unsigned int                  n_modes,
                                   const double                        tolerance,
                                   const bool                          verbose,
                                   const CutOffStop                   &stop)
  {
    const int n = K.m();
    AssertThrow(n_modes >= 1 && int(n_modes) < n - 1,
                ExcMessage("Cannot compute " + std::to_string(n_modes) + " modes of a system with " +
                           std::to_string(n) + " unknowns: lower 'Modes/Maximum number of modes' or refine the mesh."));
    EigenSolution                      solution;
    dealii::Timer                      timer;
    FoundModes<dealii::Vector<double>> found;
    solution.n_runs = 0;
    for (unsigned int nev = stop.next_batch({}, n_modes); nev > 0; nev = stop.next_batch(found.ascending(), n_modes))
      {
        if (verbose && solution.n_runs > 0)
          std::cout << "[eigensolve]   ARPACK: the " << found.size()
                    << " modes found do not decide the cut-off's count: " << nev
                    << " more, in their M-orthogonal complement" << std::endl;
        ShiftInvertArpack arpack(n, nev, tolerance);
        run_lanczos(arpack, inverse, M, found, verbose, timer, solution);
        std::vector<double> lambda, z;
        extract_eigenpairs(arpack, shift, lambda, z);
        for (unsigned int i = 0; i < nev; ++i)
          found.add(lambda[i], dealii::Vector<double>(z.begin() + std::size_t(i) * n, z.begin() + std::size_t(i + 1) * n), M);
        ++solution.n_runs;
      }
    solution.eigensolve_iteration_seconds = timer.wall_time();
    found.take_ascending(solution.eigenvalues, solution.eigenvectors);
    return solution;
  }

  std::string arpack_runs(const unsigned int runs)
  {
    return runs > 1 ? ", " + std::to_string(runs) + " runs, each in the M-orthogonal complement of the earlier ones' modes" :
                      std::string();
  }
} // namespace modal_haptics
