// The phase after the far field: full static FE at sampled candidates and pairs of contacts against
// what the kernel will compute from the basis.
#pragma once

#include "space/phase_interpolation.h"

namespace modal_haptics
{
  namespace space_phases
  {
    // Two hands on one space: pairs of neighbouring candidates (space_parts::two_contact_pairs), the
    // nearest candidates of each pair of 'Exact pair points' and pairs farther apart pushed at once
    // (in z and y), a fresh full solve each against the kernel's formula with the cross compliance,
    // u_a = B_a Lambda^-1 (B_a^T F_a + B_b^T F_b) + C_aa F_a + C_ab F_b.
    template <typename Backend>
    void validate_two_contacts(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      auto       pairs = space_parts::two_contact_pairs(result, in.scene.contact.validation_pairs);
      const auto named = space_parts::named_contact_pairs(result, in.scene, in.display);
      const auto far   = space_parts::far_contact_pairs(result, in.scene.contact.validation_pairs);
      const std::size_t first_named = pairs.size(), first_far = first_named + named.size();
      pairs.insert(pairs.end(), named.begin(), named.end());
      pairs.insert(pairs.end(), far.begin(), far.end());
      if (pairs.empty())
        return;
      std::vector<typename Backend::Field> fields;
      for (const auto &vertices : pairs)
        {
          fields.push_back(b.zero_field());
          for (unsigned int h = 0; h < 2; ++h)
            fields.back() += b.patch_load(vertices[h], space_parts::two_contact_forces[h]);
        }
      b.solve_static(fields);
      std::vector<double> values;
      for (std::size_t k = 0; k < pairs.size(); ++k)
        {
          const auto &u = b.ghosted(fields[k]);
          for (const unsigned int v : pairs[k])
            {
              const auto average = b.surface.local_patch_average(v, u);
              values.insert(values.end(), average.begin(), average.end());
            }
        }
      b.sum_over_processes(values);
      result.two_contact_checks.clear();
      for (std::size_t k = 0; k < pairs.size(); ++k)
        {
          const double *u = &values[6 * k];
          TwoContactCheck check;
          check.vertices = pairs[k];
          const auto &x = in.display.vertices;
          check.distance = std::hypot(x[pairs[k][0]][0] - x[pairs[k][1]][0], x[pairs[k][0]][1] - x[pairs[k][1]][1],
                                      x[pairs[k][0]][2] - x[pairs[k][1]][2]);
          const std::array<std::array<double, 3>, 2> full = {{{{u[0], u[1], u[2]}}, {{u[3], u[4], u[5]}}}};
          check.named                   = k >= first_named && k < first_far;
          check.far                     = k >= first_far;
          check.rel_error_corrected     = space_parts::two_contact_error(result, pairs[k], full);
          check.rel_error_without_cross = space_parts::two_contact_error(result, pairs[k], full, false);
          if (!check.far) // the exact pairs' worst; the far ones are approximations, reported per pair
            result.two_contact_rel_error_corrected = std::max(result.two_contact_rel_error_corrected, check.rel_error_corrected);
          result.two_contact_checks.push_back(check);
        }
    }

    // Full static FE for sampled candidates and the three directions, against the modal answer and
    // the corrected one. The full solve is checked by its residual, so the comparison is with a true
    // solution of K u = f, not with the correction's own numbers.
    template <typename Backend>
    void validate(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const auto        &modes = b.kept_modes();
      const unsigned int r     = modes.size();
      const std::size_t  nv    = in.display.n_vertices();
      auto               residual = b.zero_field();
      // Every case's load, then their full solutions, solved together (one pass over a factor).
      std::vector<typename Backend::Field> loads, solutions;
      for (const unsigned int vertex : in.task.validation_vertices)
        for (unsigned int direction = 0; direction < 3; ++direction)
          {
            std::array<double, 3> unit{};
            unit[direction] = 1.;
            loads.push_back(b.patch_load(vertex, unit));
            b.relieve_load(loads.back()); // a free part: the equilibrated share of the load
          }
      solutions = loads;
      b.solve_static(solutions);
      // K phi_i once: K u_modal is then their combination, and each case needs one product with K
      // (K u, for its residual and both energies) instead of three.
      std::vector<typename Backend::Field> K_modes(r, b.zero_field());
      for (unsigned int i = 0; i < r; ++i)
        b.stiffness_matrix.vmult(K_modes[i], modes[i]);
      auto K_u = b.zero_field();
      for (unsigned int k = 0; k < loads.size(); ++k)
        {
          const unsigned int vertex = in.task.validation_vertices[k / 3];
          ValidationCase     vc;
          vc.vertex    = vertex;
          vc.direction = k % 3;
          const auto &f = loads[k];
          const auto &u = solutions[k];
          b.stiffness_matrix.vmult(K_u, u);
          residual = K_u;
          residual -= f;
          vc.solve_relative_residual = residual.l2_norm() / f.l2_norm();

          auto                u_modal = b.zero_field();
          auto                K_difference = K_u; // K (u - u_modal)
          std::vector<double> modal_coefficients(r);
          for (unsigned int i = 0; i < r; ++i)
            {
              modal_coefficients[i] = (modes[i] * f) * static_gain(result.eigenvalues[i]);
              u_modal.add(modal_coefficients[i], modes[i]);
              K_difference.add(-modal_coefficients[i], K_modes[i]);
            }
          auto difference = u;
          difference -= u_modal;
          vc.energy_rel_error_modal = std::sqrt((difference * K_difference) / (u * K_u));

          // One sum over the processes: both patch averages, then both display fields.
          const auto         &u_ghosted = b.ghosted(u);
          const auto         &u_modal_ghosted = b.ghosted(u_modal);
          std::vector<double> values(6);
          const auto full  = b.surface.local_patch_average(vertex, u_ghosted);
          const auto modal = b.surface.local_patch_average(vertex, u_modal_ghosted);
          std::copy(full.begin(), full.end(), values.begin());
          std::copy(modal.begin(), modal.end(), values.begin() + 3);
          b.surface.append_local_display_values(u_ghosted, nv, values);
          b.surface.append_local_display_values(u_modal_ghosted, nv, values);
          b.sum_over_processes(values);
          std::array<double, 3> uc_full, uc_modal;
          std::copy(values.begin(), values.begin() + 3, uc_full.begin());
          std::copy(values.begin() + 3, values.begin() + 6, uc_modal.begin());
          space_parts::set_validation_errors(
            vc, result, in.display, in.scene.contact.correction_field_tolerance, uc_full, uc_modal,
            std::vector<double>(values.begin() + 6, values.begin() + 6 + 3 * nv),
            std::vector<double>(values.begin() + 6 + 3 * nv, values.end()), modal_coefficients);
          b.validation_fields.push_back(b.output_field(difference));
          result.validation.push_back(vc);
        }
      validate_two_contacts(b, in, result);
      in.log(space_parts::validation_summary(result));
    }

  } // namespace space_phases
} // namespace modal_haptics
