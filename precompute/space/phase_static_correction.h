// The phase after the interpolation: residual flexibility at the candidates, their cross
// compliance with their neighbours, and the full compliance of every load (the felt-stiffness map).
#pragma once

#include "space/phase_interpolation.h"

#include <deal.II/base/timer.h>

namespace modal_haptics
{
  namespace space_phases
  {
    // The loads' responses from the Gram matrices of their groups (the backend's group_grams): in
    // group g, the response at the group's vertex q to the load of its member p in direction d is
    // column 3p + d, rows 3q .. 3q + 2.
    template <typename Backend>
    bool record_from_group_grams(Backend &b, const PhaseInputs &in, ModalSpaceResult &result,
                                 const space_parts::StaticCorrectionPlan &plan)
    {
      const auto                      &groups = plan.blocks.groups;
      std::vector<std::vector<double>> grams;
      if (!b.group_grams(groups, grams))
        return false;
      for (std::size_t g = 0; g < groups.size(); ++g)
        {
          const auto        &vertices = groups[g].vertices;
          const std::size_t  m        = 3 * vertices.size();
          std::map<unsigned int, unsigned int> position;
          for (unsigned int k = 0; k < vertices.size(); ++k)
            position[vertices[k]] = k;
          for (unsigned int p = 0; p < plan.blocks.groups[g].n_members; ++p)
            space_parts::record_static_response(
              result, in.task, plan, plan.load_of_vertex[vertices[p]],
              [&](const unsigned int target, const unsigned int d) -> std::optional<std::array<double, 3>> {
                const auto found = position.find(target);
                if (found == position.end()) // a member of an earlier group, whose halo held vertices[p]
                  return std::nullopt;
                const std::size_t     q = found->second;
                std::array<double, 3> u;
                for (unsigned int c = 0; c < 3; ++c)
                  u[c] = grams[g][(3 * p + d) * m + 3 * q + c];
                return u;
              });
        }
      return true;
    }

    // The loads' responses by solving K u = W_v e_d a block of loads at a time and reading each
    // column's patch averages at the load itself and at its neighbours (cross compliance); the
    // averages of a block are summed over the processes once.
    template <typename Backend>
    void record_from_block_solves(Backend &b, const PhaseInputs &in, ModalSpaceResult &result,
                                  const space_parts::StaticCorrectionPlan &plan, const dealii::Timer &timer)
    {
      const auto &loads = plan.loads;
      // 16 loads (48 columns) per block: one pass over a factor serves them all.
      const unsigned int  block = std::max(1u, b.columns_per_static_solve(3 * 16) / 3);
      std::vector<double> averages;
      double              last_progress = 0.; // [s] of timer
      for (unsigned int first = 0; first < loads.size(); first += block)
        {
          const unsigned int count = std::min<unsigned int>(block, loads.size() - first);
          auto               X     = b.new_block(3 * count);
          for (unsigned int k = 0; k < count; ++k)
            b.add_patch_loads(X, 3 * k, loads[first + k]);
          b.solve_static(X);

          // Per load k and direction d, the averages at its response vertices, 3 each, in one vector.
          std::vector<std::vector<unsigned int>> targets(count);
          std::vector<std::size_t>               start(count + 1, 0);
          for (unsigned int k = 0; k < count; ++k)
            {
              targets[k]   = space_parts::response_vertices(result, plan, first + k);
              start[k + 1] = start[k] + 9 * targets[k].size();
            }
          averages.assign(start[count], 0.);
          for (unsigned int k = 0; k < count; ++k)
            for (unsigned int d = 0; d < 3; ++d)
              for (unsigned int t = 0; t < targets[k].size(); ++t)
                {
                  const auto u = b.surface.local_patch_average(targets[k][t], b.block_column(X, 3 * k + d));
                  std::copy(u.begin(), u.end(), &averages[start[k] + 3 * (d * targets[k].size() + t)]);
                }
          b.sum_over_processes(averages);
          for (unsigned int k = 0; k < count; ++k)
            space_parts::record_static_response(
              result, in.task, plan, first + k,
              [&](const unsigned int vertex, const unsigned int d) -> std::optional<std::array<double, 3>> {
                const std::size_t t = std::find(targets[k].begin(), targets[k].end(), vertex) - targets[k].begin();
                std::array<double, 3> u;
                std::copy_n(&averages[start[k] + 3 * (d * targets[k].size() + t)], 3, u.begin());
                return u;
              });
          // A line every 30 s: a block takes milliseconds over a factor, minutes without one.
          if (in.verbose && timer.wall_time() > last_progress + 30.)
            {
              last_progress = timer.wall_time();
              in.log("static correction: " + std::to_string(first + count) + " / " + std::to_string(loads.size()) +
                     " loads, " + std::to_string(int(last_progress)) + " s");
            }
        }
    }

    // Residual flexibility (mode acceleration): C_v = W_v^T K^-1 W_v - B_v Lambda^-1 B_v^T at the
    // candidates, the cross terms between neighbouring candidates, and the full W_v^T K^-1 W_v of
    // every load (the felt-stiffness map). Where the backend gives the Gram matrices of groups of
    // loads (a Cholesky factor of K: forward solves on the loads' elimination-tree paths only) they
    // come from those; else the loads are solved in blocks. For a free part K^-1 is the inertia-relief flexibility and Lambda^-1 leaves out the
    // rigid-body modes (static_gain).
    template <typename Backend>
    void compute_static_correction(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const auto        &modes = b.kept_modes();
      const unsigned int r     = modes.size();
      dealii::Timer      timer;
      auto plan = space_parts::plan_static_correction(in.scene, in.task, in.display, result);
      build_patch_loads(b, in, plan.loads);
      const double loads_built = timer.wall_time();

      // B_v = W_v^T Phi with the same W_v as the solves: then B Lambda^-1 B^T + C is W^T K^-1 W.
      plan.load_modes.assign(3 * std::size_t(r) * plan.loads.size(), 0.);
      for (unsigned int k = 0; k < plan.loads.size(); ++k)
        for (unsigned int i = 0; i < r; ++i)
          {
            const auto average = b.surface.local_patch_average(plan.loads[k], b.ghosted_kept_modes()[i]);
            for (unsigned int c = 0; c < 3; ++c)
              plan.load_modes[(3 * std::size_t(k) + c) * r + i] = average[c];
          }
      b.sum_over_processes(plan.load_modes);
      for (unsigned int a = 0; a < result.candidates.size(); ++a)
        {
          const std::size_t k = plan.load_of_vertex[result.candidates[a]];
          std::copy_n(&plan.load_modes[3 * r * k], 3 * r, &result.candidate_modes[3 * r * std::size_t(a)]);
        }

      const double modal_rows = timer.wall_time();
      if (!record_from_group_grams(b, in, result, plan))
        record_from_block_solves(b, in, result, plan, timer);
      space_parts::complete_cross_blocks(result);
      result.correction_seconds_per_candidate = plan.loads.empty() ? 0. : timer.wall_time() / plan.loads.size();
      in.log(space_parts::static_correction_summary(result, plan.loads.size()) + " (patch loads " +
             std::to_string(loads_built) + " s, modal rows " + std::to_string(modal_rows - loads_built) + " s, solves " +
             std::to_string(timer.wall_time() - modal_rows) + " s)");
    }

  } // namespace space_phases
} // namespace modal_haptics
