#include "space/far_field.h"

#include "results/quantile.h"

#include "solvers/blas_lapack.h"

#include <mrt/cross_rows.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace modal_haptics::far_field
{
  std::vector<double> gaussian_probes(const std::size_t n, const unsigned int k, const unsigned int seed)
  {
    std::mt19937_64                  random(seed);
    std::normal_distribution<double> normal;
    std::vector<double>              probes(n * k);
    for (double &x : probes)
      x = normal(random);
    return probes;
  }

  // Classical Gram-Schmidt twice (as good as the modified one twice), each pass two GEMVs over the
  // columns kept so far instead of one dot product and one update per column.
  unsigned int orthonormalize_columns(std::vector<double> &Q, const std::size_t n, const unsigned int k)
  {
    unsigned int        kept = 0;
    const int           ni   = int(n), inc = 1;
    const double        one = 1., zero = 0., minus_one = -1.;
    std::vector<double> dots(k);
    for (unsigned int j = 0; j < k; ++j)
      {
        double *q = &Q[j * n];
        double  original = 0.;
        for (std::size_t i = 0; i < n; ++i)
          original += q[i] * q[i];
        const int ki = int(kept);
        for (int pass = 0; pass < 2 && kept > 0; ++pass)
          {
            dgemv_("T", &ni, &ki, &one, Q.data(), &ni, q, &inc, &zero, dots.data(), &inc);
            dgemv_("N", &ni, &ki, &minus_one, Q.data(), &ni, dots.data(), &inc, &one, q, &inc);
          }
        double norm = 0.;
        for (std::size_t i = 0; i < n; ++i)
          norm += q[i] * q[i];
        // What is left after removing the earlier directions is rounding: no new direction.
        if (!(norm > 1e-24 * original) || norm == 0.)
          continue;
        const double scale = 1. / std::sqrt(norm);
        double      *target = &Q[kept * n];
        for (std::size_t i = 0; i < n; ++i)
          target[i] = q[i] * scale;
        ++kept;
      }
    Q.resize(kept * n);
    return kept;
  }

  std::vector<double> nystrom_factor(const std::vector<double> &Q, const std::vector<double> &Y, const std::size_t n,
                                     const unsigned int k, unsigned int &rank)
  {
    rank = 0;
    if (k == 0) // R reached no direction at all (every patch clamped)
      return {};
    // core = Q^T Y = Q^T R Q, symmetrized against rounding, then V D V^T.
    std::vector<double> core(std::size_t(k) * k, 0.);
    const int           ni = int(n), ki = int(k);
    const double        one = 1., zero = 0.;
    dgemm_("T", "N", &ki, &ki, &ni, &one, Q.data(), &ni, Y.data(), &ni, &zero, core.data(), &ki);
    for (unsigned int i = 0; i < k; ++i)
      for (unsigned int j = 0; j < i; ++j)
        core[i * k + j] = core[j * k + i] = 0.5 * (core[i * k + j] + core[j * k + i]);
    std::vector<double> eigenvalues(k);
    int                 lwork = -1, info = 0;
    double              optimal_work = 0.;
    dsyev_("V", "U", &ki, core.data(), &ki, eigenvalues.data(), &optimal_work, &lwork, &info);
    lwork = int(optimal_work);
    std::vector<double> work(std::max(1, lwork));
    dsyev_("V", "U", &ki, core.data(), &ki, eigenvalues.data(), work.data(), &lwork, &info);
    if (info != 0)
      throw std::runtime_error("far field: LAPACK's dsyev failed (info " + std::to_string(info) + ")");

    // Z = Y V_kept D_kept^{-1/2}, written row-major: Z^T = (V_kept D_kept^{-1/2})^T Y^T column-major.
    const double        largest = k > 0 ? eigenvalues.back() : 0.;
    std::vector<double> scaled; // k x rank, column-major
    for (unsigned int j = 0; j < k; ++j)
      if (largest > 0. && eigenvalues[j] > 1e-12 * largest)
        for (unsigned int p = 0; p < k; ++p)
          scaled.push_back(core[j * k + p] / std::sqrt(eigenvalues[j])); // eigenvector j is column j of core
    rank = scaled.size() / k;
    std::vector<double> Z(n * rank, 0.);
    const int           ri = int(rank);
    if (rank > 0)
      dgemm_("T", "T", &ri, &ni, &ki, &one, scaled.data(), &ki, Y.data(), &ni, &zero, Z.data(), &ri);
    return Z;
  }

  std::vector<unsigned int> sample_candidates(const unsigned int nc, const unsigned int count, const unsigned int seed)
  {
    std::vector<unsigned int> all(nc);
    for (unsigned int a = 0; a < nc; ++a)
      all[a] = a;
    std::mt19937 random(seed);
    std::shuffle(all.begin(), all.end(), random);
    all.resize(std::min(nc, count));
    std::sort(all.begin(), all.end());
    return all;
  }

  namespace
  {
    double frobenius(const std::array<double, 9> &A)
    {
      double sum = 0.;
      for (const double x : A)
        sum += x * x;
      return std::sqrt(sum);
    }
  } // namespace

  ErrorByDistance error_by_distance(const ModalSpaceResult &result, const std::vector<std::array<double, 3>> &positions,
                                    const std::vector<unsigned int> &sampled, const std::vector<double> &exact)
  {
    ErrorByDistance out;
    double          sum_error = 0., sum_alone = 0.;
    std::size_t     count = 0;
    static const std::vector<double> edges = {0., 0.005, 0.01, 0.02, 0.04, 0.08, 1e30}; // [m]
    const std::size_t   nc = result.candidates.size(), n = 3 * nc;
    std::vector<std::vector<double>> errors(edges.size() - 1), alone(edges.size() - 1);
    for (std::size_t t = 0; t < sampled.size(); ++t)
      {
        const unsigned int s = sampled[t];
        std::array<double, 9> own_s;
        std::copy_n(&result.candidate_compliance[9 * std::size_t(s)], 9, own_s.begin());
        for (unsigned int b = 0; b < nc; ++b)
          {
            if (b == s || mrt::cross_position(result.cross_offsets.data(), result.cross_neighbours.data(), s, b) >= 0)
              continue;
            std::array<double, 9> own_b, R{}, far{}, error{};
            std::copy_n(&result.candidate_compliance[9 * std::size_t(b)], 9, own_b.begin());
            const double scale = std::sqrt(frobenius(own_s) * frobenius(own_b));
            if (!(scale > 0.))
              continue;
            mrt::far_coupling(result.far_compliance.data(), result.far_rank, b, s, far.data());
            for (unsigned int i = 0; i < 3; ++i)
              for (unsigned int d = 0; d < 3; ++d)
                {
                  R[3 * i + d]     = exact[(3 * t + d) * n + 3 * b + i]; // at b along i, s's load along d
                  error[3 * i + d] = R[3 * i + d] - far[3 * i + d];
                }
            const auto  &x = positions[result.candidates[s]], &y = positions[result.candidates[b]];
            const double distance = std::hypot(x[0] - y[0], x[1] - y[1], x[2] - y[2]);
            const std::size_t band =
              std::upper_bound(edges.begin(), edges.end(), distance) - edges.begin() - 1;
            errors[band].push_back(frobenius(error) / scale);
            alone[band].push_back(frobenius(R) / scale);
            sum_error += std::pow(errors[band].back(), 2), sum_alone += std::pow(alone[band].back(), 2), ++count;
          }
      }
    if (count > 0)
      out.rms_error = std::sqrt(sum_error / count), out.rms_modes_alone = std::sqrt(sum_alone / count);
    for (std::size_t band = 0; band + 1 < edges.size(); ++band)
      {
        if (errors[band].empty())
          continue;
        FarFieldBand b;
        b.from               = edges[band];
        b.to                 = edges[band + 1];
        b.pairs              = errors[band].size();
        b.median_error       = quantile(errors[band], 0.5);
        b.p95_error          = quantile(errors[band], 0.95);
        b.max_error          = *std::max_element(errors[band].begin(), errors[band].end());
        b.median_modes_alone = quantile(alone[band], 0.5);
        b.p95_modes_alone    = quantile(alone[band], 0.95);
        out.bands.push_back(b);
      }
    return out;
  }
} // namespace modal_haptics::far_field
