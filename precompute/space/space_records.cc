// What the static correction and the validation of a space record, whatever its linear algebra
// (space_parts in modal_space.h): the loads' plan, the compliances read off each solve, the
// refinement of shifted static solves, the validation errors and their summaries.
#include "space/space_parts.h"

#include <mrt/cross_rows.h>
#include <mrt/surface_normals.h>

#include <deal.II/base/exceptions.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  namespace space_parts
  {
    std::array<double, 3> modal_patch_response(const ModalSpaceResult &result, const unsigned int candidate,
                                               const unsigned int direction)
    {
      const unsigned int r = result.eigenvalues.size();
      const double      *B = &result.candidate_modes[std::size_t(candidate) * 3 * r];
      std::array<double, 3> u{};
      for (unsigned int i = 0; i < r; ++i)
        {
          const double q = B[direction * r + i] * static_gain(result.eigenvalues[i]);
          for (unsigned int c = 0; c < 3; ++c)
            u[c] += B[c * r + i] * q;
        }
      return u;
    }

    // The shared vertices (compared across spaces) are solved with the candidates.
    void record_iteration(ModalSpaceResult &result, const EigenSolution &solution)
    {
      result.n_operator_applications      = solution.n_operator_applications;
      result.eigensolve_iteration_seconds = solution.eigensolve_iteration_seconds;
      result.mass_product_seconds         = solution.mass_product_seconds;
      result.orthogonalization_seconds    = solution.orthogonalization_seconds;
    }

    StaticCorrectionPlan plan_static_correction(const SceneParameters &scene, const SpaceTask &task,
                                                const ContactSurface &display, ModalSpaceResult &result)
    {
      const unsigned int nv = display.n_vertices();
      result.candidates     = task.candidates;
      const unsigned int nc = result.candidates.size();
      StaticCorrectionPlan plan;
      std::set_union(result.candidates.begin(), result.candidates.end(), task.shared_vertices.begin(),
                     task.shared_vertices.end(), std::back_inserter(plan.loads));
      plan.load_of_vertex.assign(nv, -1);
      for (unsigned int k = 0; k < plan.loads.size(); ++k)
        plan.load_of_vertex[plan.loads[k]] = int(k);

      const std::vector<double>       positions = flatten(display.vertices);
      const std::vector<unsigned int> triangles = flatten(display.triangles);
      plan.normals.resize(3 * std::size_t(nv));
      mrt::area_weighted_normals(positions.data(), nv, triangles.data(), display.triangles.size(), plan.normals.data());
      const double radius = scene.contact.cross_compliance ? scene.contact.cross_compliance_radius * scene.length_unit : -1.;
      const auto   links  = exact_pair_links(positions, triangles, result.candidates, exact_pair_points(scene),
                                             scene.contact.exact_pair_reach * scene.length_unit);
      // 64 loads (192 columns) a group, with their halo: wide enough for the BLAS, close enough
      // together to share their paths in the elimination tree, and the halo (the members'
      // neighbours in later groups) a smaller share than with smaller groups.
      plan.blocks = plan_contact_blocks(positions, triangles, plan.loads, result.candidates, radius, 64, links);

      result.candidate_modes.assign(3 * std::size_t(nc) * result.eigenvalues.size(), 0.);
      result.candidate_compliance.assign(9 * std::size_t(nc), 0.);
      result.cross_offsets.clear();
      result.cross_neighbours.clear();
      result.cross_blocks.clear();
      if (radius >= 0. && nc > 0)
        {
          result.cross_offsets    = plan.blocks.neighbours.offsets;
          result.cross_neighbours = plan.blocks.neighbours.neighbours;
          // NaN until recorded: a block left out of every solve is found by complete_cross_blocks.
          result.cross_blocks.assign(9 * result.cross_neighbours.size(), std::numeric_limits<double>::quiet_NaN());
        }
      result.felt_stiffness.assign(nv, 0.);
      result.modal_only_stiffness.assign(nv, 0.);
      return plan;
    }

    std::vector<unsigned int> response_vertices(const ModalSpaceResult &result, const StaticCorrectionPlan &plan,
                                                const unsigned int load)
    {
      const unsigned int        vertex = plan.loads[load];
      std::vector<unsigned int> vertices{vertex};
      const auto found = std::lower_bound(result.candidates.begin(), result.candidates.end(), vertex);
      if (found != result.candidates.end() && *found == vertex && !result.cross_offsets.empty())
        {
          const unsigned int a = found - result.candidates.begin();
          for (unsigned int k = result.cross_offsets[a]; k < result.cross_offsets[a + 1]; ++k)
            vertices.push_back(result.candidates[result.cross_neighbours[k]]);
        }
      return vertices;
    }

    namespace
    {
      // B_a Lambda^-1 B_b^T (3 x 3 row-major) from two loads' modal rows.
      std::array<double, 9> modal_compliance(const ModalSpaceResult &result, const double *Ba, const double *Bb)
      {
        const unsigned int    r = result.eigenvalues.size();
        std::array<double, 9> C{};
        for (unsigned int c = 0; c < 3; ++c)
          for (unsigned int d = 0; d < 3; ++d)
            for (unsigned int i = 0; i < r; ++i)
              C[3 * c + d] += Ba[c * r + i] * Bb[d * r + i] * static_gain(result.eigenvalues[i]);
        return C;
      }

      // 1 / (n^T C n) [N/m]; 0 where C gives no compliance along n: a vertex without triangles, or
      // one whose patch lies on clamped DoFs (its stiffness would be round-off's 1e30 N/m and more;
      // above 1e15 N/m, far stiffer than any contact of a real part, it counts as none).
      double normal_stiffness(const std::array<double, 9> &C, const double *n)
      {
        double compliance = 0.;
        for (unsigned int c = 0; c < 3; ++c)
          for (unsigned int d = 0; d < 3; ++d)
            compliance += n[c] * C[3 * c + d] * n[d];
        return compliance > 1e-15 ? 1. / compliance : 0.;
      }
    } // namespace

    void record_static_response(ModalSpaceResult &result, const SpaceTask &task, const StaticCorrectionPlan &plan,
                                const unsigned int load,
                                const std::function<std::optional<std::array<double, 3>>(unsigned int, unsigned int)> &averaged)
    {
      const unsigned int r = result.eigenvalues.size(), vertex = plan.loads[load];
      const double      *B = &plan.load_modes[3 * std::size_t(r) * load];
      // W_target^T K^-1 W_v, row-major, where the solve gives the response at target.
      const auto compliance_with = [&](const unsigned int target) -> std::optional<std::array<double, 9>> {
        std::array<double, 9> G{};
        for (unsigned int d = 0; d < 3; ++d)
          {
            const auto u = averaged(target, d);
            if (!u)
              return std::nullopt;
            for (unsigned int c = 0; c < 3; ++c)
              G[3 * c + d] = (*u)[c];
          }
        return G;
      };
      const std::array<double, 9> G     = compliance_with(vertex).value();
      const std::array<double, 9> modal = modal_compliance(result, B, B);
      result.felt_stiffness[vertex]       = normal_stiffness(G, &plan.normals[3 * std::size_t(vertex)]);
      result.modal_only_stiffness[vertex] = normal_stiffness(modal, &plan.normals[3 * std::size_t(vertex)]);
      if (std::binary_search(task.shared_vertices.begin(), task.shared_vertices.end(), vertex))
        result.full_compliance[vertex] = G;
      const auto found = std::lower_bound(result.candidates.begin(), result.candidates.end(), vertex);
      if (found == result.candidates.end() || *found != vertex)
        return;
      const unsigned int a = found - result.candidates.begin();
      for (unsigned int k = 0; k < 9; ++k)
        result.candidate_compliance[9 * std::size_t(a) + k] = G[k] - modal[k];
      if (result.cross_offsets.empty())
        return;
      // Block (a, b) = W_a^T R W_b in a's row: by symmetry, entry (c, d) is the response at b along
      // d to a's load along c, the transpose of what this load's solve reads at b.
      for (unsigned int k = result.cross_offsets[a]; k < result.cross_offsets[a + 1]; ++k)
        {
          const unsigned int target    = result.candidates[result.cross_neighbours[k]];
          const auto         at_target = compliance_with(target);
          if (!at_target) // solved with the target's load: complete_cross_blocks
            continue;
          const double *Bt       = &plan.load_modes[3 * std::size_t(r) * plan.load_of_vertex[target]];
          const auto    modal_ab = modal_compliance(result, B, Bt);
          for (unsigned int c = 0; c < 3; ++c)
            for (unsigned int d = 0; d < 3; ++d)
              result.cross_blocks[9 * std::size_t(k) + 3 * c + d] = (*at_target)[3 * d + c] - modal_ab[3 * c + d];
        }
    }

    void complete_cross_blocks(ModalSpaceResult &result)
    {
      const auto &offsets = result.cross_offsets, &neighbours = result.cross_neighbours;
      for (unsigned int a = 0; a + 1 < offsets.size(); ++a)
        for (unsigned int k = offsets[a]; k < offsets[a + 1]; ++k)
          {
            double *block = &result.cross_blocks[9 * std::size_t(k)];
            if (!std::isnan(block[0]))
              continue;
            const unsigned int b       = neighbours[k];
            const auto         first   = neighbours.begin() + offsets[b], last = neighbours.begin() + offsets[b + 1];
            const auto         reverse = std::lower_bound(first, last, a);
            AssertThrow(reverse != last && *reverse == a && !std::isnan(result.cross_blocks[9 * (reverse - neighbours.begin())]),
                        dealii::ExcMessage("Internal error: the cross block of candidates " + std::to_string(a) + " and " +
                                           std::to_string(b) + " was solved from neither of them."));
            const double *transposed = &result.cross_blocks[9 * std::size_t(reverse - neighbours.begin())];
            for (unsigned int c = 0; c < 3; ++c)
              for (unsigned int d = 0; d < 3; ++d)
                block[3 * c + d] = transposed[3 * d + c];
          }
    }

    std::string static_correction_summary(const ModalSpaceResult &result, const std::size_t n_loads)
    {
      std::ostringstream line;
      line << "static correction: " << n_loads << " loads (" << result.candidates.size() << " candidates, "
           << result.cross_neighbours.size() << " neighbour pairs within the cross compliance radius), "
           << result.correction_seconds_per_candidate * 1e3 << " ms per load";
      return line.str();
    }

    std::string far_field_summary(const ModalSpaceResult &result)
    {
      std::ostringstream line;
      line << "far field: rank " << result.far_rank << " for " << result.candidates.size() << " candidates, "
           << result.far_field_seconds << " s; residual coupling error, median (modes alone) by distance:";
      for (const auto &band : result.far_field_bands)
        line << ' ' << band.from * 1e3 << (band.to > 1e29 ? "+" : "-" + std::to_string(int(band.to * 1e3))) << " mm "
             << std::setprecision(2) << band.median_error << " (" << band.median_modes_alone << ")"
             << std::setprecision(6);
      return line.str();
    }

    unsigned int refine_static_solve(const std::function<double()> &refine, const std::string &space_name,
                                     const double shift_hz)
    {
      double previous = std::numeric_limits<double>::infinity();
      for (unsigned int step = 1;; ++step)
        {
          const double worst = refine();
          if (worst <= 1e-12)
            return step;
          // No longer shrinking: the rounding floor (a direct solve of K itself reaches about 1e-9
          // on a slender part), or no convergence at all.
          const bool stalled = worst >= 0.5 * previous;
          AssertThrow((!stalled || worst <= 1e-6) && step < 200,
                      ExcMessage("Space '" + space_name + "': the static solves do not converge with 'Modes/Shift' = " +
                                 std::to_string(shift_hz) + " Hz (relative residual " + [&] { std::ostringstream r; r << worst; return r.str(); }() +
                                 " after " + std::to_string(step) + " refinements): choose a shift of smaller magnitude, "
                                 "well below the first elastic frequency."));
          if (stalled)
            return step;
          previous = worst;
        }
    }

    // Display field: modal vs full. The correction field d = full - modal is local; kept only where
    // |d| >= tolerance * max |d| (how it would be stored sparsely), the corrected field misses the
    // dropped part.
    // Area-weighted l2 error of the modal display field against full_field (3 per display vertex)
    // with the first k modes, k = 1..r, relative to full_field: how the drawn field converges with r.
    std::vector<double> display_error_by_mode_count(const ModalSpaceResult &result, const ContactSurface &display,
                                                    const std::vector<double> &full_field,
                                                    const std::vector<double> &modal_coefficient)
    {
      const unsigned int  r = modal_coefficient.size();
      std::vector<double> remainder = full_field, errors;
      double              full_norm = 0.;
      for (std::size_t row = 0; row < full_field.size(); ++row)
        full_norm += display.vertex_area[row / 3] * full_field[row] * full_field[row];
      for (unsigned int k = 0; k < r; ++k)
        {
          double error = 0.;
          for (std::size_t row = 0; row < remainder.size(); ++row)
            {
              remainder[row] -= modal_coefficient[k] * result.display_modes[row * r + k];
              error += display.vertex_area[row / 3] * remainder[row] * remainder[row];
            }
          errors.push_back(std::sqrt(error / full_norm));
        }
      return errors;
    }

    void set_validation_errors(ValidationCase &vc, const ModalSpaceResult &result, const ContactSurface &display,
                               const double correction_field_tolerance, const std::array<double, 3> &uc_full,
                               const std::array<double, 3> &uc_modal, const std::vector<double> &display_full,
                               const std::vector<double> &display_modal, const std::vector<double> &modal_coefficients)
    {
      const auto candidate_it = std::lower_bound(result.candidates.begin(), result.candidates.end(), vc.vertex);
      Assert(candidate_it != result.candidates.end() && *candidate_it == vc.vertex, ExcInternalError());
      const std::size_t candidate = candidate_it - result.candidates.begin();
      vc.full_response = uc_full;
      double full_norm = 0., modal_err = 0., corrected_err = 0.;
      for (unsigned int c = 0; c < 3; ++c)
        {
          const double corrected = uc_modal[c] + result.candidate_compliance[9 * candidate + 3 * c + vc.direction];
          full_norm += uc_full[c] * uc_full[c];
          modal_err += std::pow(uc_modal[c] - uc_full[c], 2);
          corrected_err += std::pow(corrected - uc_full[c], 2);
        }
      vc.contact_rel_error_modal     = std::sqrt(modal_err / full_norm);
      vc.contact_rel_error_corrected = std::sqrt(corrected_err / full_norm);

      const unsigned int  nv = display.n_vertices();
      std::vector<double> error2(nv, 0.), full2(nv, 0.);
      for (unsigned int v = 0; v < nv; ++v)
        for (unsigned int c = 0; c < 3; ++c)
          {
            const double full  = display_full[3 * v + c];
            const double modal = display_modal[3 * v + c];
            full2[v] += full * full;
            error2[v] += (modal - full) * (modal - full);
          }
      const double max_error = std::sqrt(*std::max_element(error2.begin(), error2.end()));
      const double max_full  = std::sqrt(*std::max_element(full2.begin(), full2.end()));
      const double keep      = correction_field_tolerance * max_error;
      double l2_full = 0., l2_err = 0., l2_corr = 0.;
      vc.correction_field_vertices = 0;
      for (unsigned int v = 0; v < nv; ++v)
        {
          l2_full += full2[v] * display.vertex_area[v];
          l2_err += error2[v] * display.vertex_area[v];
          if (std::sqrt(error2[v]) >= keep)
            ++vc.correction_field_vertices;
          else
            l2_corr += error2[v] * display.vertex_area[v];
        }
      vc.field_rel_error_modal     = std::sqrt(l2_err / l2_full);
      vc.field_max_error_modal     = max_error / max_full;
      vc.field_rel_error_corrected = std::sqrt(l2_corr / l2_full);
      vc.field_rel_error_by_modes  = display_error_by_mode_count(result, display, display_full, modal_coefficients);
    }

    std::array<double, 9> residual_compliance(const ModalSpaceResult &result, const unsigned int a, const unsigned int b)
    {
      std::array<double, 9> C{};
      if (a == b)
        std::copy_n(&result.candidate_compliance[9 * std::size_t(a)], 9, C.begin());
      else if (const std::ptrdiff_t k = result.cross_offsets.empty() ? -1 :
                   mrt::cross_position(result.cross_offsets.data(), result.cross_neighbours.data(), a, b);
               k >= 0)
        std::copy_n(&result.cross_blocks[9 * std::size_t(k)], 9, C.begin());
      else
        mrt::far_coupling(result.far_compliance.data(), result.far_rank, a, b, C.data());
      return C;
    }

    std::vector<std::array<unsigned int, 2>> two_contact_pairs(const ModalSpaceResult &result, const unsigned int count)
    {
      std::vector<std::array<unsigned int, 2>> pairs;
      std::vector<unsigned int>                with_neighbours;
      for (unsigned int a = 0; a + 1 < result.cross_offsets.size(); ++a)
        if (result.cross_offsets[a + 1] > result.cross_offsets[a])
          with_neighbours.push_back(a);
      std::mt19937 random(20261127u + result.index); // a fixed seed: the same pairs every run
      for (unsigned int k = 0; k < count && !with_neighbours.empty(); ++k)
        {
          const unsigned int a = with_neighbours[random() % with_neighbours.size()];
          const unsigned int n = result.cross_offsets[a + 1] - result.cross_offsets[a];
          const unsigned int b = result.cross_neighbours[result.cross_offsets[a] + random() % n];
          pairs.push_back({{result.candidates[a], result.candidates[b]}});
        }
      return pairs;
    }

    std::vector<std::array<std::array<double, 3>, 2>> exact_pair_points(const SceneParameters &scene)
    {
      std::vector<std::array<std::array<double, 3>, 2>> points;
      for (const auto &pair : scene.contact.exact_pairs)
        {
          auto &ends = points.emplace_back();
          for (unsigned int e = 0; e < 2; ++e)
            for (unsigned int c = 0; c < 3; ++c)
              ends[e][c] = pair[e][c] * scene.length_unit;
        }
      return points;
    }

    std::vector<std::array<unsigned int, 2>> named_contact_pairs(const ModalSpaceResult &result, const SceneParameters &scene,
                                                                 const ContactSurface &display)
    {
      const std::vector<double>                positions = flatten(display.vertices);
      std::vector<std::array<unsigned int, 2>> pairs;
      const double reach = scene.contact.exact_pair_reach * scene.length_unit;
      for (const auto &ends : exact_pair_points(scene))
        {
          const int a = nearest_candidate(positions, result.candidates, ends[0], reach);
          const int b = nearest_candidate(positions, result.candidates, ends[1], reach);
          if (a >= 0 && b >= 0 && a != b)
            pairs.push_back({{result.candidates[a], result.candidates[b]}});
        }
      return pairs;
    }

    std::vector<std::array<unsigned int, 2>> far_contact_pairs(const ModalSpaceResult &result, const unsigned int count)
    {
      std::vector<std::array<unsigned int, 2>> pairs;
      const unsigned int                       nc = result.candidates.size();
      std::mt19937 random(20261128u + result.index); // a fixed seed: the same pairs every run
      for (unsigned int attempt = 0; result.far_rank > 0 && pairs.size() < count && attempt < 100 * count; ++attempt)
        {
          const unsigned int a = random() % nc, b = random() % nc;
          if (a != b && mrt::cross_position(result.cross_offsets.data(), result.cross_neighbours.data(), a, b) < 0)
            pairs.push_back({{result.candidates[a], result.candidates[b]}});
        }
      return pairs;
    }

    // The kernel's formula: u_a = B_a Lambda^-1 (B_a^T F_a + B_b^T F_b) + C_aa F_a + C_ab F_b.
    double two_contact_error(const ModalSpaceResult &result, const std::array<unsigned int, 2> &vertices,
                             const std::array<std::array<double, 3>, 2> &full_responses, const bool with_cross_residual)
    {
      const unsigned int r = result.eigenvalues.size();
      const auto        &forces = two_contact_forces;
      std::array<unsigned int, 2> index{};
      for (unsigned int h = 0; h < 2; ++h)
        index[h] = std::lower_bound(result.candidates.begin(), result.candidates.end(), vertices[h]) -
                   result.candidates.begin();
      std::vector<double> modal_force(r, 0.); // sum_h B_h^T F_h
      for (unsigned int h = 0; h < 2; ++h)
        for (unsigned int c = 0; c < 3; ++c)
          for (unsigned int i = 0; i < r; ++i)
            modal_force[i] += result.candidate_modes[(index[h] * 3 + c) * r + i] * forces[h][c];
      double worst = 0.;
      for (unsigned int h = 0; h < 2; ++h)
        {
          const auto &full  = full_responses[h];
          double      error = 0., norm = 0.;
          for (unsigned int c = 0; c < 3; ++c)
            {
              double predicted = 0.;
              for (unsigned int i = 0; i < r; ++i)
                predicted += result.candidate_modes[(index[h] * 3 + c) * r + i] * modal_force[i] * static_gain(result.eigenvalues[i]);
              for (unsigned int g = 0; g < 2; ++g)
                {
                  if (g != h && !with_cross_residual)
                    continue;
                  const auto C = residual_compliance(result, index[h], index[g]);
                  for (unsigned int d = 0; d < 3; ++d)
                    predicted += C[3 * c + d] * forces[g][d];
                }
              error += std::pow(predicted - full[c], 2);
              norm += full[c] * full[c];
            }
          worst = std::max(worst, std::sqrt(error / norm));
        }
      return worst;
    }

    std::string validation_summary(const ModalSpaceResult &result)
    {
      double worst_modal = 0., worst_corrected = 0.;
      for (const auto &vc : result.validation)
        {
          worst_modal     = std::max(worst_modal, vc.contact_rel_error_modal);
          worst_corrected = std::max(worst_corrected, vc.contact_rel_error_corrected);
        }
      std::ostringstream line;
      line << "validation: " << result.validation.size() << " full static solves; contact error modal-only up to "
           << worst_modal << ", corrected up to " << worst_corrected;
      double       worst_far = 0., worst_without = 0.;
      unsigned int n_far     = 0;
      for (const auto &check : result.two_contact_checks)
        if (check.far)
          {
            ++n_far;
            worst_far     = std::max(worst_far, check.rel_error_corrected);
            worst_without = std::max(worst_without, check.rel_error_without_cross);
          }
      if (n_far > 0)
        line << "; " << n_far << " pairs farther apart pressed together: error with the far field up to " << worst_far
             << " (without it " << worst_without << ")";
      for (const auto &check : result.two_contact_checks)
        if (check.named)
          line << "; exact pair points at vertices " << check.vertices[0] << " and " << check.vertices[1] << " ("
               << check.distance * 1e3 << " mm apart) pressed together: error " << check.rel_error_corrected
               << " (the modes alone between them " << check.rel_error_without_cross << ")";
      return line.str();
    }
  } // namespace space_parts
} // namespace modal_haptics
