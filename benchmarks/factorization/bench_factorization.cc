// bench-factorization: the numeric supernodal Cholesky factorization of a space's stiffness matrix,
// ours (factorize_supernodal: subtrees of the elimination tree on the threads, precompute/solvers/
// supernodal_cholesky.h) against its peer cholmod_l_factorize (the supernodes in order, the BLAS on
// every thread), both on one CHOLMOD analysis (METIS), in a rotating order per repetition (against
// the machine's drift). Prints a comment line, then CSV: the median seconds of each, the GFLOP/s they
// reach (CHOLMOD's flop count of the factor) and the median of CHOLMOD's time over ours in the same
// repetition. Every repetition also checks that the two factors agree (to 1e-10 of the largest entry).
//
//   bench-factorization K.csr [--repetitions 3] [--threads N]
//
// K is a space's stiffness matrix exported by modal-precompute ('Output/Export matrices'); threads:
// ours' threads (default: the cores, as the precompute's factorization takes them).
#include "../command_line.h"
#include "../eigensolver/csr_file.h"

#include "solvers/factorization.h" // apply_openblas_settings
#include "solvers/supernodal_cholesky.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace
{
  struct Options
  {
    std::string  matrix;
    int          repetitions = 3;
    unsigned int threads     = std::max(1u, std::thread::hardware_concurrency());
  };

  Options parse(int argc, char **argv)
  {
    const char *usage = "bench-factorization K.csr [--repetitions N] [--threads N]";
    Options     o;
    modal_haptics_bench::parse_file_and_options(argc, argv, o.matrix, [&](const std::string &name, const std::string &value) {
      if (name == "--repetitions")
        o.repetitions = std::stoi(value);
      else if (name == "--threads")
        o.threads = std::stoul(value);
      else
        return false;
      return true;
    }, usage);
    if (o.repetitions < 1 || o.threads < 1)
      modal_haptics_bench::usage(usage);
    return o;
  }

  // The exported CSR (both triangles; its rows are the CSC columns of a symmetric matrix) as
  // CHOLMOD's stype 1, as the precompute hands it over.
  cholmod_sparse *to_cholmod(const modal_haptics_bench::Csr &csr, cholmod_common &common)
  {
    cholmod_sparse *A = cholmod_l_allocate_sparse(csr.n, csr.n, csr.nnz, 0, 1, 1, CHOLMOD_REAL, &common);
    if (A == nullptr)
      throw std::runtime_error("out of memory for the matrix");
    std::copy(csr.row_start.begin(), csr.row_start.end(), static_cast<SuiteSparse_long *>(A->p));
    std::copy(csr.columns.begin(), csr.columns.end(), static_cast<SuiteSparse_long *>(A->i));
    std::copy(csr.values.begin(), csr.values.end(), static_cast<double *>(A->x));
    return A;
  }

  double seconds_since(const std::chrono::steady_clock::time_point start)
  {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  double median(std::vector<double> values)
  {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
  }

  // One numeric factorization on a copy of the analysis: seconds, and the factor (freed by the caller).
  double factorize(const bool ours, cholmod_sparse *A, const cholmod_factor *analysis, const Options &o,
                   cholmod_common &common, cholmod_factor *&factor)
  {
    factor           = cholmod_l_copy_factor(const_cast<cholmod_factor *>(analysis), &common);
    const auto start = std::chrono::steady_clock::now();
    const bool positive_definite =
      ours ? modal_haptics::factorize_supernodal(*A, *factor, common, o.threads) == SuiteSparse_long(factor->n)
           : cholmod_l_factorize(A, factor, &common) && factor->minor == factor->n;
    const double seconds = seconds_since(start);
    if (!positive_definite)
      throw std::runtime_error(o.matrix + " is not positive definite (not a stiffness matrix with its supports?)");
    return seconds;
  }
} // namespace

int main(int argc, char **argv)
{
  modal_haptics::apply_openblas_settings(argv);
  const Options  o = parse(argc, argv);
  cholmod_common common;
  cholmod_l_start(&common);
  try
    {
      cholmod_sparse *A         = to_cholmod(modal_haptics_bench::read_csr(o.matrix), common);
      common.nmethods           = 1;
      common.method[0].ordering = CHOLMOD_METIS;
      common.supernodal         = CHOLMOD_SUPERNODAL;
      cholmod_factor *analysis  = cholmod_l_analyze(A, &common);
      if (analysis == nullptr)
        throw std::runtime_error("CHOLMOD's analysis failed");
      const double flops = common.fl;
      std::printf("# bench-factorization: %s, %ld DoFs, %.3g nonzeros in L, %.3g flops, %ld supernodes; ours on %u "
                  "threads\n",
                  o.matrix.c_str(), long(A->nrow), common.lnz, flops, long(analysis->nsuper), o.threads);
      std::vector<double> ours_seconds, cholmod_seconds, ratios;
      double              largest_difference = 0.;
      for (int k = 0; k < o.repetitions; ++k)
        {
          cholmod_factor *factors[2];
          double          seconds[2];
          for (int j = 0; j < 2; ++j)
            {
              const bool ours   = (j + k) % 2 == 0;
              seconds[ours]     = factorize(ours, A, analysis, o, common, factors[ours]);
            }
          const auto  *x = static_cast<const double *>(factors[1]->x), *y = static_cast<const double *>(factors[0]->x);
          const std::size_t size = factors[0]->xsize;
          double       largest = 0., difference = 0.;
          for (std::size_t i = 0; i < size; ++i)
            {
              largest    = std::max(largest, std::abs(y[i]));
              difference = std::max(difference, std::abs(x[i] - y[i]));
            }
          largest_difference = std::max(largest_difference, difference / largest);
          for (auto &factor : factors)
            cholmod_l_free_factor(&factor, &common);
          ours_seconds.push_back(seconds[1]);
          cholmod_seconds.push_back(seconds[0]);
          ratios.push_back(seconds[0] / seconds[1]);
        }
      if (!(largest_difference <= 1e-10))
        throw std::runtime_error("the two factors differ by " + std::to_string(largest_difference) +
                                 " of the largest entry");
      std::printf("n_dofs,factor_nonzeros,gflop,threads,repetitions,ours_s_median,cholmod_s_median,ours_gflops,"
                  "cholmod_gflops,cholmod_over_ours_median,largest_difference\n");
      std::printf("%ld,%.0f,%.2f,%u,%d,%.3f,%.3f,%.1f,%.1f,%.2f,%.1e\n", long(A->nrow), common.lnz, flops / 1e9,
                  o.threads, o.repetitions, median(ours_seconds), median(cholmod_seconds),
                  flops / median(ours_seconds) / 1e9, flops / median(cholmod_seconds) / 1e9, median(ratios),
                  largest_difference);
      cholmod_l_free_factor(&analysis, &common);
      cholmod_l_free_sparse(&A, &common);
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "bench-factorization: %s\n", e.what());
      cholmod_l_finish(&common);
      return 1;
    }
  cholmod_l_finish(&common);
  return 0;
}
