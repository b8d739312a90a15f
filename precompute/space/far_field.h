// The far field of the residual compliance between a space's candidates: R = W^T (K^-1 - Phi
// Lambda^+ Phi^T) W over every candidate's patch loads (3 nc rows), symmetric positive
// semi-definite, approximated as Z Z^T from products of R with a few blocks of loads (a randomized
// Nystrom approximation with one power step: Halko, Martinsson and Tropp 2011). The kernel couples
// two candidates without a stored cross block by Z_a Z_b^T; R - Z Z^T stays positive semi-definite,
// so a pair's exact own blocks with that coupling never make the pair's compliance indefinite.
// Pure linear algebra on column-major blocks (no deal.II); phase_far_field.h applies R.
#pragma once

#include "results/space_result.h"

#include <array>
#include <vector>

namespace modal_haptics::far_field
{
  // n x k standard normal numbers, column-major, the same for a seed on every process.
  std::vector<double> gaussian_probes(std::size_t n, unsigned int k, unsigned int seed);

  // Orthonormalizes the k columns of Q (n x k, column-major) in place by Gram-Schmidt, twice (the
  // second pass restores what rounding lost); columns left with no new direction are dropped and
  // the rest moved forward. Returns the number kept.
  unsigned int orthonormalize_columns(std::vector<double> &Q, std::size_t n, unsigned int k);

  // Z with Z Z^T = Y (Q^T Y)^+ Y^T, for Q with orthonormal columns and Y = R Q (n x k each): the
  // eigenvalues of Q^T Y below 1e-12 of the largest are dropped (directions R barely reaches).
  // Z is n x rank, row-major (entry i rank + j), as the .mrt stores it per candidate.
  std::vector<double> nystrom_factor(const std::vector<double> &Q, const std::vector<double> &Y, std::size_t n,
                                     unsigned int k, unsigned int &rank);

  // Up to 'count' candidates (indices into nc) spread at random with a fixed seed, ascending.
  std::vector<unsigned int> sample_candidates(unsigned int nc, unsigned int count, unsigned int seed);

  // The factor's error by distance: exact holds R's columns at the sampled candidates (column 3 t + d
  // is the response to sampled[t]'s load along d; n rows each, column-major). Pairs with a stored
  // cross block (result.cross_offsets/neighbours) or of a candidate with itself are left out; the
  // rest is binned by the distance between the two candidates' display vertices.
  // Also the root mean square of the pairs' errors, with the factor and with the modes alone.
  struct ErrorByDistance
  {
    std::vector<FarFieldBand> bands;
    double                    rms_error = 0., rms_modes_alone = 0.;
  };
  ErrorByDistance error_by_distance(const ModalSpaceResult &result, const std::vector<std::array<double, 3>> &positions,
                                    const std::vector<unsigned int> &sampled, const std::vector<double> &exact);
} // namespace modal_haptics::far_field
