#include "solvers/eigensolver.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/arpack_solver.h> // declares ARPACK's dsaupd_ and dseupd_

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

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
    // hand us M x already computed.
    void apply_shift_invert(Factorization &inverse, const dealii::SparseMatrix<double> &M,
                            const int ido, const int n, double *workd, const int *ipntr,
                            dealii::Vector<double> &x, dealii::Vector<double> &y)
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

    // The Lanczos iteration: dsaupd until it converges, applying the shift-invert operator and M
    // when asked. Counts the operator applications and the restarts in `solution`.
    void run_lanczos(ShiftInvertArpack &arpack, Factorization &inverse, const dealii::SparseMatrix<double> &M,
                     const bool verbose, const dealii::Timer &timer, EigenSolution &solution)
    {
      const int              n = arpack.n;
      dealii::Vector<double> x(n), y(n);
      while (true)
        {
          const int ido = arpack.step();
          if (ido == -1 || ido == 1)
            {
              apply_shift_invert(inverse, M, ido, n, arpack.workd.data(), arpack.ipntr.data(), x, y);
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
      solution.n_restarts = arpack.iparam[2];
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

    // The eigenpairs into `solution`, eigenvalues ascending (ARPACK does not promise an order), each
    // vector normalized in M again so that round-off does not accumulate (ARPACK's are M-orthonormal).
    void store_sorted_eigenpairs(const std::vector<double> &lambda, const std::vector<double> &z,
                                 const dealii::SparseMatrix<double> &M, EigenSolution &solution)
    {
      const std::size_t         n = M.m();
      std::vector<unsigned int> order(lambda.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](unsigned a, unsigned b) { return lambda[a] < lambda[b]; });
      for (const unsigned int i : order)
        {
          solution.eigenvalues.push_back(lambda[i]);
          dealii::Vector<double> phi(n);
          std::copy(z.begin() + i * n, z.begin() + (i + 1) * n, phi.begin());
          phi /= std::sqrt(M.matrix_norm_square(phi));
          solution.eigenvectors.push_back(std::move(phi));
        }
    }
  } // namespace

  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &inverse,
                                   const double                        shift,
                                   const unsigned int                  n_modes,
                                   const double                        tolerance,
                                   const bool                          verbose)
  {
    const int n   = K.m();
    const int nev = n_modes;
    AssertThrow(nev >= 1 && nev < n - 1,
                ExcMessage("Cannot compute " + std::to_string(nev) + " modes of a system with " +
                           std::to_string(n) + " unknowns: lower 'Modes/Maximum number of modes' or refine the mesh."));
    ShiftInvertArpack arpack(n, nev, tolerance);
    EigenSolution     solution;
    dealii::Timer     timer;
    run_lanczos(arpack, inverse, M, verbose, timer, solution);
    std::vector<double> lambda, z;
    extract_eigenpairs(arpack, shift, lambda, z);
    solution.eigensolve_iteration_seconds = timer.wall_time();
    store_sorted_eigenpairs(lambda, z, M, solution);
    return solution;
  }
} // namespace modal_haptics
