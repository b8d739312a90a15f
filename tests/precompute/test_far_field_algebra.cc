// The far field's algebra (precompute/space/far_field.h) on matrices whose answer is known:
// * orthonormalize_columns: orthonormal columns spanning the input's, a repeated column dropped;
// * nystrom_factor: a positive semi-definite R of rank 5 (n = 30) is reproduced exactly (Z Z^T = R to
//   rounding) from k = 8 random probes, whatever the probes; for R of full rank with a decaying
//   spectrum, R - Z Z^T stays positive semi-definite (the factor never overshoots) and its error is
//   below the (k+1)-th eigenvalue's scale times a small factor; no direction at all gives rank 0;
// * error_by_distance: with the exact R and Z of it, the errors are rounding and the modes-alone
//   figures |R_ab| / sqrt(|C_aa| |C_bb|); stored neighbour pairs are left out.
#include "checks.h"
#include "space/far_field.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

using namespace modal_haptics;
using testing::check;

namespace
{
  // R = sum_j s_j v_j v_j^T (n x n, column-major) with random orthonormal v_j.
  std::vector<double> psd_matrix(const std::size_t n, const std::vector<double> &spectrum, const unsigned int seed)
  {
    auto V = far_field::gaussian_probes(n, spectrum.size(), seed);
    far_field::orthonormalize_columns(V, n, spectrum.size());
    std::vector<double> R(n * n, 0.);
    for (std::size_t j = 0; j < spectrum.size(); ++j)
      for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = 0; b < n; ++b)
          R[b * n + a] += spectrum[j] * V[j * n + a] * V[j * n + b];
    return R;
  }

  std::vector<double> times(const std::vector<double> &R, const std::vector<double> &X, const std::size_t n,
                            const unsigned int k)
  {
    std::vector<double> Y(n * k, 0.);
    for (unsigned int j = 0; j < k; ++j)
      for (std::size_t b = 0; b < n; ++b)
        for (std::size_t a = 0; a < n; ++a)
          Y[j * n + a] += R[b * n + a] * X[j * n + b];
    return Y;
  }

  // The factor of R from k probes as compute_far_field builds it: R Omega, orthonormalized, R Q.
  std::vector<double> factor_of(const std::vector<double> &R, const std::size_t n, const unsigned int k,
                                unsigned int &rank)
  {
    auto               Q  = times(R, far_field::gaussian_probes(n, k, 7), n, k);
    const unsigned int kq = far_field::orthonormalize_columns(Q, n, k);
    return far_field::nystrom_factor(Q, times(R, Q, n, kq), n, kq, rank);
  }

  // max |R - Z Z^T| / max |R|, and the smallest eigenvalue-like quantity min_x x^T (R - Z Z^T) x over
  // random unit x (a cheap check of semi-definiteness).
  void compare(const std::vector<double> &R, const std::vector<double> &Z, const std::size_t n, const unsigned int rank,
               double &error, double &least)
  {
    double scale = 0.;
    error        = 0.;
    std::vector<double> E(n * n);
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = 0; b < n; ++b)
        {
          double zz = 0.;
          for (unsigned int j = 0; j < rank; ++j)
            zz += Z[a * rank + j] * Z[b * rank + j];
          E[b * n + a] = R[b * n + a] - zz;
          error        = std::max(error, std::abs(E[b * n + a]));
          scale        = std::max(scale, std::abs(R[b * n + a]));
        }
    error /= scale;
    least = 1e300;
    const auto X = far_field::gaussian_probes(n, 200, 11);
    for (unsigned int t = 0; t < 200; ++t)
      {
        const double *x = &X[t * n];
        double        xx = 0., xEx = 0.;
        for (std::size_t a = 0; a < n; ++a)
          {
            xx += x[a] * x[a];
            for (std::size_t b = 0; b < n; ++b)
              xEx += x[a] * E[b * n + a] * x[b];
          }
        least = std::min(least, xEx / xx / scale);
      }
  }
} // namespace

int main()
{
  const std::size_t n = 30;
  {
    auto Q = far_field::gaussian_probes(n, 4, 3);
    std::copy_n(&Q[0], n, &Q[3 * n]); // column 3 repeats column 0
    const unsigned int kept = far_field::orthonormalize_columns(Q, n, 4);
    double             worst = 0.;
    for (unsigned int i = 0; i < kept; ++i)
      for (unsigned int j = 0; j < kept; ++j)
        {
          double dot = 0.;
          for (std::size_t a = 0; a < n; ++a)
            dot += Q[i * n + a] * Q[j * n + a];
          worst = std::max(worst, std::abs(dot - (i == j ? 1. : 0.)));
        }
    char line[120];
    std::snprintf(line, sizeof line, "orthonormalize_columns: %u of 4 columns kept (one repeated), |Q^T Q - I| = %.1e",
                  kept, worst);
    check(kept == 3 && worst < 1e-14, line);
  }
  {
    const auto   R = psd_matrix(n, {5., 3., 2., 1., 0.5}, 1);
    unsigned int rank = 0;
    const auto   Z = factor_of(R, n, 8, rank);
    double       error = 0., least = 0.;
    compare(R, Z, n, rank, error, least);
    char line[160];
    std::snprintf(line, sizeof line, "rank-5 R from 8 probes: rank %u, max |R - Z Z^T| / max |R| = %.1e", rank, error);
    check(rank == 5 && error < 1e-12, line);
  }
  {
    std::vector<double> spectrum;
    for (unsigned int j = 0; j < n; ++j)
      spectrum.push_back(std::pow(0.7, j));
    const auto   R = psd_matrix(n, spectrum, 2);
    unsigned int rank = 0;
    const auto   Z = factor_of(R, n, 10, rank);
    double       error = 0., least = 0.;
    compare(R, Z, n, rank, error, least);
    char line[200];
    std::snprintf(line, sizeof line,
                  "full-rank R (eigenvalues 0.7^j) from 10 probes: R - Z Z^T >= 0 (least x^T E x / |R| = %.1e), "
                  "max error %.1e <= 5 x 0.7^10 = %.1e",
                  least, error, 5. * std::pow(0.7, 10));
    check(rank == 10 && least > -1e-13 && error <= 5. * std::pow(0.7, 10), line);
  }
  {
    unsigned int rank = 1;
    const auto   Z = far_field::nystrom_factor({}, {}, n, 0, rank);
    check(rank == 0 && Z.empty(), "no direction: rank 0, an empty factor");
  }
  {
    // Four candidates on a line 10 mm apart; candidates 0 and 1 stored neighbours; Z exact for R.
    const std::size_t   nc = 4, m = 3 * nc;
    std::vector<double> spectrum(m);
    for (std::size_t j = 0; j < m; ++j)
      spectrum[j] = 1. + j;
    const auto       R = psd_matrix(m, spectrum, 3);
    ModalSpaceResult result;
    result.candidates       = {0, 1, 2, 3};
    result.cross_offsets    = {0, 1, 2, 2, 2};
    result.cross_neighbours = {1, 0};
    for (std::size_t a = 0; a < nc; ++a)
      for (unsigned int i = 0; i < 3; ++i)
        for (unsigned int d = 0; d < 3; ++d)
          result.candidate_compliance.push_back(R[(3 * a + d) * m + 3 * a + i]);
    result.far_compliance = factor_of(R, m, m, result.far_rank);
    std::vector<std::array<double, 3>> positions = {{{0., 0., 0.}}, {{0.01, 0., 0.}}, {{0.02, 0., 0.}}, {{0.03, 0., 0.}}};
    const std::vector<unsigned int> sampled = {0};
    std::vector<double>             exact(m * 3);
    for (unsigned int d = 0; d < 3; ++d)
      for (std::size_t row = 0; row < m; ++row)
        exact[d * m + row] = R[d * m + row];
    const auto measured = far_field::error_by_distance(result, positions, sampled, exact);
    std::size_t pairs = 0;
    double      worst = 0.;
    for (const auto &band : measured.bands)
      pairs += band.pairs, worst = std::max(worst, band.max_error);
    check(pairs == 2 && worst < 1e-12 && measured.rms_modes_alone > 0.,
          "error_by_distance: candidate 0 against 2 and 3 (1 is a stored neighbour): " + std::to_string(pairs) +
            " pairs, errors " + std::to_string(worst) + ", modes alone rms " + std::to_string(measured.rms_modes_alone));
  }
  return testing::exit_code();
}
