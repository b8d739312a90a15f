#include "eigensolver.h"

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
  } // namespace

  EigenSolution solve_shift_invert(const dealii::SparseMatrix<double> &K,
                                   const dealii::SparseMatrix<double> &M,
                                   Factorization                      &inverse,
                                   const double                        shift,
                                   const unsigned int                  n_modes,
                                   const double                        tolerance,
                                   const bool                          verbose)
  {
    (void)K;
    int n   = K.m();
    int nev = n_modes;
    AssertThrow(nev >= 1 && nev < n - 1,
                ExcMessage("Cannot compute " + std::to_string(nev) + " modes of a system with " +
                           std::to_string(n) + " unknowns: lower 'Modes/Maximum number of modes' or refine the mesh."));
    // Twice the wanted count plus a margin: the usual ARPACK advice, and what converged fastest on
    // our panels (about two Lanczos restarts for 50 modes).
    int ncv = std::min(n - 1, std::max(2 * nev + 10, 20));
    // deal.II declares ARPACK's n and nev as unsigned.
    unsigned int n_arpack = n, nev_arpack = nev;

    int                 ido = 0, info = 0;
    char                bmat[2]  = "G";
    char                which[3] = "LM"; // largest of 1/(lambda - sigma): closest to the shift
    double              tol      = tolerance;
    std::vector<double> resid(n, 1.), v(std::size_t(n) * ncv), workd(3 * std::size_t(n)),
      workl(std::size_t(ncv) * (ncv + 8));
    int                 lworkl = workl.size();
    std::vector<int>    iparam(11, 0), ipntr(14, 0);
    iparam[0] = 1;      // exact shifts
    iparam[2] = 10000;  // maximum restarts
    iparam[6] = 3;      // shift-invert mode

    EigenSolution          solution;
    dealii::Vector<double> x(n), y(n);
    dealii::Timer          timer;
    while (true)
      {
        dealii::dsaupd_(&ido, bmat, &n_arpack, which, &nev_arpack, &tol, resid.data(), &ncv, v.data(), &n, iparam.data(),
                ipntr.data(), workd.data(), workl.data(), &lworkl, &info);
        if (ido == -1 || ido == 1)
          {
            apply_shift_invert(inverse, M, ido, n, workd.data(), ipntr.data(), x, y);
            ++solution.n_operator_applications;
            if (verbose && solution.n_operator_applications % 25 == 0)
              std::cout << "[eigensolve]   " << solution.n_operator_applications << " solves, "
                        << timer.wall_time() << " s" << std::endl;
          }
        else if (ido == 2)
          {
            std::copy(workd.begin() + ipntr[0] - 1, workd.begin() + ipntr[0] - 1 + n, x.begin());
            M.vmult(y, x);
            std::copy(y.begin(), y.end(), workd.begin() + ipntr[1] - 1);
          }
        else
          break;
      }
    AssertThrow(info >= 0, ExcMessage(arpack_error("dsaupd", info)));
    AssertThrow(info != 1, ExcMessage(arpack_error("dsaupd", info)));
    solution.n_restarts = iparam[2];

    int                 rvec    = 1;
    char                howmany = 'A';
    std::vector<int>    select(ncv, 1);
    std::vector<double> lambda(nev), z(std::size_t(n) * nev);
    double              sigma = shift;
    dealii::dseupd_(&rvec, &howmany, select.data(), lambda.data(), z.data(), &n, &sigma, bmat, &n_arpack, which, &nev_arpack,
            &tol, resid.data(), &ncv, v.data(), &n, iparam.data(), ipntr.data(), workd.data(),
            workl.data(), &lworkl, &info);
    AssertThrow(info == 0, ExcMessage(arpack_error("dseupd", info)));
    const int n_converged = iparam[4];
    AssertThrow(n_converged >= nev,
                ExcMessage("ARPACK converged only " + std::to_string(n_converged) + " of " +
                           std::to_string(nev) + " modes."));
    solution.eigensolve_iteration_seconds = timer.wall_time();

    // ARPACK does not promise an order: sort ascending.
    std::vector<unsigned int> order(nev);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](unsigned a, unsigned b) { return lambda[a] < lambda[b]; });
    for (const unsigned int i : order)
      {
        solution.eigenvalues.push_back(lambda[i]);
        dealii::Vector<double> phi(n);
        std::copy(z.begin() + std::size_t(i) * n, z.begin() + std::size_t(i + 1) * n, phi.begin());
        // ARPACK's vectors are M-orthonormal; normalize again so that round-off does not accumulate.
        phi /= std::sqrt(M.matrix_norm_square(phi));
        solution.eigenvectors.push_back(std::move(phi));
      }
    return solution;
  }
} // namespace modal_haptics
