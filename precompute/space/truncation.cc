// truncate_modal_space (modal_space.h): a space with fewer modes, for modal-study.
#include "results/space_result.h"

#include <deal.II/base/exceptions.h>

#include <algorithm>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    // Adds sum_{i in [r_kept, r)} B_a[c][i] B_b[d][i] / lambda_i to the 3 x 3 block (row-major)
    // `target` of candidates a and b (B: 3 rows of r mode values per candidate).
    void add_dropped_modes(const std::vector<double> &B, const unsigned int r, const unsigned int r_kept,
                           const std::vector<double> &eigenvalues, const std::size_t a, const std::size_t b,
                           double *target)
    {
      for (unsigned int c = 0; c < 3; ++c)
        for (unsigned int d = 0; d < 3; ++d)
          for (unsigned int i = r_kept; i < r; ++i)
            target[3 * c + d] += B[(3 * a + c) * r + i] * B[(3 * b + d) * r + i] * static_gain(eigenvalues[i]);
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
      {
        add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, a, a, &kept.candidate_compliance[9 * a]);
        for (std::size_t k = space.cross_offsets.empty() ? 0 : space.cross_offsets[a];
             k < (space.cross_offsets.empty() ? 0 : space.cross_offsets[a + 1]); ++k)
          add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, a, space.cross_neighbours[k],
                            &kept.cross_blocks[9 * k]);
      }
    // The felt-stiffness map is the full FE's, whatever the count; modal_only_stiffness stays the
    // computed count's (the map's comparison, not a quantity of the truncated basis).
    for (unsigned int i = r_kept; i < r; ++i)
      kept.dropped_modes.push_back({i, space.frequencies_hz[i], "truncated to " + std::to_string(r_kept) + " modes"});
    return kept;
  }
} // namespace modal_haptics
