// What a factorization and an eigensolve report of themselves (report.json): plain records, with no
// deal.II or solver headers, so that readers of results (space/space_result.h) compile without them.
#pragma once

#include <string>

namespace modal_haptics
{
  struct FactorizationStatistics
  {
    std::string method;             // "cholmod-supernodal-metis" or "umfpack-lu"
    double analyze_seconds   = 0.;  // ordering and symbolic analysis
    double factorize_seconds = 0.;
    double factor_nonzeros   = 0.;  // entries of L (or L + U)
    double predicted_factor_bytes = 0.; // CHOLMOD: the factor's values as its analysis sizes them
    double factor_flops      = 0.;  // floating point operations of the numeric factorization (CHOLMOD)
    double solve_seconds     = 0.;  // accumulated over every solve
    unsigned long n_solved_vectors = 0;
    unsigned int  solve_threads    = 1;  // threads of the triangular solves (CHOLMOD: SupernodalSolve's)
  };

  struct EigenSelfCheck
  {
    double orthonormality_error   = 0.; // max |Phi^T M Phi - I|
    double max_relative_residual  = 0.; // max ||K phi - lambda M phi|| / ||lambda M phi||
  };
} // namespace modal_haptics
