// What the static correction and the validation of a space record, whatever its linear algebra
// (space_parts in modal_space.h): the loads' plan, the compliances read off each solve, the
// refinement of shifted static solves, the validation errors and their summaries.
#include "space/modal_space.h"

#include <deal.II/base/exceptions.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
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

    std::vector<unsigned int> plan_static_correction(const SceneParameters &scene, const SpaceTask &task,
                                                     ModalSpaceResult &result)
    {
      result.candidates     = task.candidates;
      const unsigned int nc = result.candidates.size();
      std::vector<unsigned int> loads = result.candidates;
      for (const unsigned int v : task.shared_vertices)
        if (!std::binary_search(result.candidates.begin(), result.candidates.end(), v))
          loads.push_back(v);
      result.candidate_modes.assign(3 * std::size_t(nc) * result.eigenvalues.size(), 0.);
      result.candidate_compliance.assign(9 * std::size_t(nc), 0.);
      if (scene.contact.cross_compliance && nc > 0)
        result.cross_compliance.assign(9 * std::size_t(nc) * nc, 0.);
      return loads;
    }

    void record_static_response(ModalSpaceResult &result, const SpaceTask &task, const unsigned int load,
                                const unsigned int load_vertex,
                                const std::function<std::array<double, 3>(unsigned int, unsigned int)> &averaged)
    {
      const unsigned int r = result.eigenvalues.size(), nc = result.candidates.size();
      // Full compliance at the load itself.
      std::array<double, 9> G{};
      for (unsigned int d = 0; d < 3; ++d)
        {
          const auto u = averaged(load_vertex, d);
          for (unsigned int c = 0; c < 3; ++c)
            G[3 * c + d] = u[c];
        }
      if (std::binary_search(task.shared_vertices.begin(), task.shared_vertices.end(), load_vertex))
        result.full_compliance[load_vertex] = G;
      if (load >= nc)
        return;
      for (unsigned int d = 0; d < 3; ++d)
        {
          const auto u_modal = modal_patch_response(result, load, d);
          for (unsigned int c = 0; c < 3; ++c)
            result.candidate_compliance[9 * std::size_t(load) + 3 * c + d] = G[3 * c + d] - u_modal[c];
        }
      if (result.cross_compliance.empty())
        return;
      const unsigned int stride = 3 * nc;
      const double      *Bb     = &result.candidate_modes[std::size_t(load) * 3 * r];
      for (unsigned int a = 0; a < nc; ++a)
        {
          const double *Ba = &result.candidate_modes[std::size_t(a) * 3 * r];
          for (unsigned int d = 0; d < 3; ++d)
            {
              const auto u = averaged(result.candidates[a], d);
              for (unsigned int c = 0; c < 3; ++c)
                {
                  double modal = 0.;
                  for (unsigned int i = 0; i < r; ++i)
                    modal += Ba[c * r + i] * Bb[d * r + i] * static_gain(result.eigenvalues[i]);
                  result.cross_compliance[std::size_t(3 * a + c) * stride + 3 * load + d] = u[c] - modal;
                }
            }
        }
    }

    std::string static_correction_summary(const ModalSpaceResult &result, const std::size_t n_loads)
    {
      const unsigned int nc = result.candidates.size();
      std::ostringstream line;
      line << "static correction: " << nc << " candidates (" << n_loads - nc << " shared vertices), "
           << result.correction_seconds_per_candidate * 1e3 << " ms per load";
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

    // The kernel's formula: u_a = B_a Lambda^-1 (B_a^T F_a + B_b^T F_b) + C_aa F_a + C_ab F_b.
    double two_contact_error(const ModalSpaceResult &result, const std::array<unsigned int, 2> &vertices,
                             const std::array<std::array<double, 3>, 2> &full_responses)
    {
      const unsigned int r = result.eigenvalues.size(), nc = result.candidates.size();
      const auto        &forces = two_contact_forces;
      std::array<std::size_t, 2> index{};
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
                for (unsigned int d = 0; d < 3; ++d)
                  predicted += result.cross_compliance[(3 * index[h] + c) * 3 * nc + 3 * index[g] + d] * forces[g][d];
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
      return line.str();
    }
  } // namespace space_parts
} // namespace modal_haptics
