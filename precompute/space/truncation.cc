// truncate_modal_space (modal_space.h): a space with fewer modes, for modal-study.
#include "space/space_result.h"

#include <deal.II/base/exceptions.h>

#include <algorithm>
#include <numeric>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    // Adds sum_{i in [r_kept, r)} B[p][i] B[q][i] / lambda_i to the (rows x rows) block `target` for
    // the rows of B listed in `rows` (B: one row of r mode values per contact direction).
    void add_dropped_modes(const std::vector<double> &B, const unsigned int r, const unsigned int r_kept,
                           const std::vector<double> &eigenvalues, const std::vector<std::size_t> &rows, double *target)
    {
      for (std::size_t p = 0; p < rows.size(); ++p)
        for (std::size_t q = 0; q < rows.size(); ++q)
          for (unsigned int i = r_kept; i < r; ++i)
            target[p * rows.size() + q] += B[rows[p] * r + i] * B[rows[q] * r + i] * static_gain(eigenvalues[i]);
    }

    // Keeps the first r_kept of every block of r values.
    std::vector<double> keep_leading(const std::vector<double> &values, const unsigned int r, const unsigned int r_kept)
    {
      std::vector<double> kept;
      kept.reserve(values.size() / r * r_kept);
      for (std::size_t start = 0; start < values.size(); start += r)
        kept.insert(kept.end(), values.begin() + start, values.begin() + start + r_kept);
      return kept;
    }
  } // namespace

  ModalSpaceResult truncate_modal_space(const ModalSpaceResult &space, const unsigned int r_kept)
  {
    const unsigned int r = space.eigenvalues.size();
    AssertThrow(r_kept >= 1 && r_kept <= r,
                ExcMessage("Space '" + space.name + "' has " + std::to_string(r) + " modes; " + std::to_string(r_kept) +
                           " cannot be kept."));
    ModalSpaceResult kept = space;
    for (auto *list : {&kept.eigenvalues, &kept.frequencies_hz, &kept.damping_ratios})
      list->resize(r_kept);
    kept.participation.resize(std::size_t(r_kept) * 6);
    kept.modes_at_vertices.resize(std::size_t(r_kept) * space.n_vertex_rows() * 3);
    kept.display_modes   = keep_leading(space.display_modes, r, r_kept);
    kept.candidate_modes = keep_leading(space.candidate_modes, r, r_kept);

    const std::size_t nc = space.candidates.size();
    for (std::size_t a = 0; a < nc; ++a)
      add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, {3 * a, 3 * a + 1, 3 * a + 2},
                        &kept.candidate_compliance[9 * a]);
    if (!space.cross_compliance.empty())
      {
        std::vector<std::size_t> every_row(3 * nc);
        std::iota(every_row.begin(), every_row.end(), 0);
        add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, every_row, kept.cross_compliance.data());
      }
    for (unsigned int i = r_kept; i < r; ++i)
      kept.dropped_modes.push_back({i, space.frequencies_hz[i], "truncated to " + std::to_string(r_kept) + " modes"});
    return kept;
  }
} // namespace modal_haptics
