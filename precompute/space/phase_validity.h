// The phases after the validation: the validity map's estimate at every corrected contact, and the
// nonlinear solves at the validity contacts (nonlinear/large_deformation.h), serial and distributed.
#pragma once

#include "nonlinear/large_deformation.h"
#include "space/backend.h"

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace modal_haptics
{
  namespace space_phases
  {
    // Both validity phases over one backend; they share the estimate's modal side, built once.
    template <typename Backend>
    class ValidityPhases
    {
    public:
      using Summarize = std::function<void(std::string)>; // a summary line (SpaceBase::summarize)

      // The validity map, estimated where the felt-stiffness map is positive (large_deformation.h).
      void estimate(Backend &b, const PhaseInputs &in, const dealii::Mapping<3> &mapping,
                    const dealii::Quadrature<3> &quadrature, ModalSpaceResult &result, const Summarize &summarize)
      {
        nonlinear::estimate_validity_map(
          in.display, [&] { return modal_view(b, in, mapping, quadrature); }, result, summarize);
      }

      // The large-deformation solves at the validity contacts.
      void analyse(Backend &b, const PhaseInputs &in, const dealii::Mapping<3> &mapping,
                   const dealii::Quadrature<3> &quadrature, ModalSpaceResult &result, const Summarize &summarize)
      {
        nonlinear::analyse_validity(
          b.validity_space(), in.scene, in.task, in.display,
          [&b](const unsigned int v, const std::array<double, 3> &d) { return b.patch_load(v, d); },
          [&b](const meshing::Point3 &x) {
            double outside = 0.;
            b.evaluation_points({x}, &outside);
            return outside;
          },
          [&]() -> std::optional<nonlinear::ModalView> {
            if (in.scene.contact.validity_estimate)
              return modal_view(b, in, mapping, quadrature);
            return std::nullopt;
          },
          result, in.log, summarize);
      }

    private:
      // The validity estimate's modal side (large_deformation.h), built on first use: the cubic term
      // on the lowest modes, and B_v^T on them at every vertex with a patch load (the corrected
      // contacts and shared vertices), each process's part summed over the processes at once.
      nonlinear::ModalView modal_view(Backend &b, const PhaseInputs &in, const dealii::Mapping<3> &mapping,
                                      const dealii::Quadrature<3> &quadrature)
      {
        if (!cubic_term)
          {
            const auto sum = [&b](std::vector<double> &values) { b.sum_over_processes(values); };
            cubic_term     = std::make_unique<nonlinear::ModalCubicTerm>(b.dof_handler, mapping, quadrature,
                                                                     in.scene.material, nonlinear::validity_law(in.scene),
                                                                     b.ghosted_kept_modes(), sum);
            const unsigned int r = cubic_term->size();
            for (const auto &[vertex, load] : b.surface.patch_loads)
              {
                modal_load_row[vertex] = modal_loads.size() / (3 * std::size_t(r));
                for (unsigned int i = 0; i < r; ++i)
                  {
                    const auto average = b.surface.local_patch_average(vertex, b.ghosted_kept_modes()[i]);
                    modal_loads.insert(modal_loads.end(), average.begin(), average.end());
                  }
              }
            sum(modal_loads);
          }
        const std::vector<dealii::Vector<double>> *serial_modes = nullptr;
        if constexpr (std::is_same_v<typename Backend::Field, dealii::Vector<double>>)
          serial_modes = &b.kept_modes();
        return {serial_modes, *cubic_term, [this](const unsigned int vertex, const std::array<double, 3> &d) {
                  const unsigned int r   = cubic_term->size();
                  const double      *row = &modal_loads[3 * std::size_t(r) * modal_load_row.at(vertex)];
                  std::vector<double> b(r);
                  for (unsigned int i = 0; i < r; ++i)
                    b[i] = d[0] * row[3 * i] + d[1] * row[3 * i + 1] + d[2] * row[3 * i + 2];
                  return b;
                }};
      }

      std::unique_ptr<nonlinear::ModalCubicTerm> cubic_term;
      std::vector<double>                        modal_loads; // per vertex with a patch load: r x 3, B_v^T
      std::map<unsigned int, std::size_t>        modal_load_row;
    };
  } // namespace space_phases
} // namespace modal_haptics
