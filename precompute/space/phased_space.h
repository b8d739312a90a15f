// A space whose phases after the eigensolve are written once over its backend (backend.h), one file
// per phase: phase_interpolation.h, phase_static_correction.h, phase_far_field.h,
// phase_validation.h, phase_validity.h, phase_output.h. Their order is SpaceBase::run()'s
// (space_parts.cc). A backend derives from PhasedSpace<itself> and implements assembly and the
// eigensolve (SpaceBase) and the operations backend.h lists. The phases are templates: a backend's
// translation unit (modal_space.cc, distributed_space.cc) instantiates them, so no phase adds one.
#pragma once

#include "space/phase_far_field.h"
#include "space/phase_interpolation.h"
#include "space/phase_output.h"
#include "space/phase_static_correction.h"
#include "space/phase_validation.h"
#include "space/phase_validity.h"

namespace modal_haptics
{
  namespace space_phases
  {
    template <typename Backend>
    class PhasedSpace : public space_parts::SpaceBase
    {
    public:
      using SpaceBase::SpaceBase;

    protected:
      void interpolate() override
      {
        interpolate_on_display_surface(backend(), inputs(), result);
        compute_participation_factors(backend(), result);
      }
      void compute_static_correction() override { space_phases::compute_static_correction(backend(), inputs(), result); }
      void compute_far_field() override { space_phases::compute_far_field(backend(), inputs(), result); }
      void validate() override { space_phases::validate(backend(), inputs(), result); }
      void output_results() const override
      {
        space_phases::output_results(static_cast<const Backend &>(*this), inputs(), result);
      }
      void estimate_validity() override
      {
        validity.estimate(backend(), inputs(), mapping, quadrature, result,
                          [this](const std::string &line) { summarize(line); });
      }
      void analyse_validity() override
      {
        validity.analyse(backend(), inputs(), mapping, quadrature, result,
                         [this](const std::string &line) { summarize(line); });
      }

    private:
      Backend &backend() { return static_cast<Backend &>(*this); }

      ValidityPhases<Backend> validity;
    };
  } // namespace space_phases
} // namespace modal_haptics
