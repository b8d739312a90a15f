// The phase after the static correction: the residual coupling of candidates farther apart than
// the stored cross blocks reach, as a low-rank factor (its algebra: far_field.h).
#pragma once

#include "space/backend.h"
#include "space/far_field.h"

#include <deal.II/base/timer.h>

#include <sstream>

namespace modal_haptics
{
  namespace space_phases
  {
    // R X for blocks of candidate loads: column j of X holds 3 nc weights (the load sum_a W_a x_a);
    // the answer, W^T (K^-1 - Phi Lambda^+ Phi^T) W X, is 3 nc x k column-major like X, the same on
    // every process. Blocks of columns share a pass over the factor.
    template <typename Backend>
    std::vector<double> apply_residual_compliance(Backend &b, const ModalSpaceResult &result, const std::vector<double> &X,
                                                  const unsigned int k)
    {
      const auto        &candidates = result.candidates;
      const std::size_t  n          = 3 * candidates.size();
      const unsigned int r          = result.eigenvalues.size();
      std::vector<double> Y(n * k, 0.);
      const unsigned int  per_solve = std::max(1u, b.columns_per_static_solve(k));
      const auto          rows      = b.surface.patch_rows(candidates);
      for (unsigned int first = 0; first < k; first += per_solve)
        {
          const unsigned int count = std::min(per_solve, k - first);
          auto               block = b.new_block(count);
          b.add_combined_patch_loads(block, rows, &X[first * n], count);
          b.solve_static(block);
          b.patch_row_averages(block, rows, count, &Y[first * n]);
        }
      b.sum_over_processes(Y);
      // The modal part, B Lambda^+ B^T X, with B the candidates' modal rows.
      const auto &B = result.candidate_modes;
      for (unsigned int j = 0; j < k; ++j)
        {
          std::vector<double> q(r, 0.);
          for (std::size_t row = 0; row < n; ++row)
            for (unsigned int i = 0; i < r; ++i)
              q[i] += B[row * r + i] * X[j * n + row];
          for (unsigned int i = 0; i < r; ++i)
            q[i] *= static_gain(result.eigenvalues[i]);
          for (std::size_t row = 0; row < n; ++row)
            for (unsigned int i = 0; i < r; ++i)
              Y[j * n + row] -= B[row * r + i] * q[i];
        }
      return Y;
    }

    // The residual coupling of candidates farther apart than the stored blocks reach, as the factor
    // Z of a randomized Nystrom approximation R ~ Z Z^T (far_field.h): R applied to 'Far field rank'
    // random loads, the answers orthonormalized, R applied once more (a power step: the local
    // response each patch has of its own, which R's random image mixes in, weighs less against the
    // coupling that reaches far). Its error is measured against R's exact columns at a few sampled
    // candidates and reported by distance.
    template <typename Backend>
    void compute_far_field(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const std::size_t nc = result.candidates.size(), n = 3 * nc;
      if (in.scene.contact.far_field_rank == 0 || result.cross_offsets.empty() || nc < 2)
        return;
      const unsigned int k = std::min<std::size_t>(in.scene.contact.far_field_rank, n);
      dealii::Timer      timer;
      const unsigned int seed = 20261127u + result.index;
      std::vector<double> Q   = apply_residual_compliance(b, result, far_field::gaussian_probes(n, k, seed), k);
      const unsigned int  kq  = far_field::orthonormalize_columns(Q, n, k);
      const std::vector<double> Y = apply_residual_compliance(b, result, Q, kq);
      result.far_compliance       = far_field::nystrom_factor(Q, Y, n, kq, result.far_rank);
      result.far_field_seconds    = timer.wall_time();

      const auto sampled = far_field::sample_candidates(nc, 8, seed);
      std::vector<double> units(n * 3 * sampled.size(), 0.);
      for (std::size_t t = 0; t < sampled.size(); ++t)
        for (unsigned int d = 0; d < 3; ++d)
          units[(3 * t + d) * n + 3 * sampled[t] + d] = 1.;
      const auto exact = apply_residual_compliance(b, result, units, 3 * sampled.size());
      const auto measured              = far_field::error_by_distance(result, in.display.vertices, sampled, exact);
      result.far_field_bands           = measured.bands;
      result.far_field_rms_error       = measured.rms_error;
      result.far_field_rms_modes_alone = measured.rms_modes_alone;
      result.far_field_sampled.clear();
      for (const unsigned int s : sampled)
        result.far_field_sampled.push_back(result.candidates[s]);
      in.log(space_parts::far_field_summary(result) + " (checked against " + std::to_string(3 * sampled.size()) +
             " exact solves in " + std::to_string(timer.wall_time() - result.far_field_seconds) + " s)");
      // Where the residual coupling is mostly each patch's own (a stiff, compact part), a rank-k
      // factor cannot hold it, and at single pairs its error can exceed the coupling itself: a factor
      // that does not remove at least half of what the modes alone leave out is not kept.
      if (!(measured.rms_error < 0.5 * measured.rms_modes_alone))
        {
          std::ostringstream why;
          why << "at the sampled pairs its error (rms " << measured.rms_error << " of the contacts' own compliance) "
              << "is not below half of what the modes alone leave out (" << measured.rms_modes_alone << ")";
          result.far_field_left_out = why.str();
          result.far_compliance.clear();
          result.far_rank = 0;
          in.log("far field not kept: " + result.far_field_left_out);
        }
    }

  } // namespace space_phases
} // namespace modal_haptics
