// The self-check: the full-FE validation cases stored in the basis, replayed through the kernel.
// Each case is a unit force at a display vertex; the kernel is put at the exact static equilibrium
// under it (so no time is spent waiting for slow, lightly damped modes to settle), runs one
// admittance tick from there (a fixed point of the exact integrator, so the tick keeps it) and
// reports the felt displacement u_c, which must equal W_v^T K^-1 W_v e_dir.
#include "self_check.h"

#include "error.h"
#include "kernel.h"

#include <cmath>

namespace modalrt
{
  namespace
  {
    modalrt_kernel_def verification_def(const modalrt_basis &basis, std::uint32_t space)
    {
      modalrt_kernel_def def    = modalrt_kernel_default_def();
      def.hip_capacity          = 1;
      def.initial_space         = space;
      def.switch_rule           = MODALRT_SWITCH_NEVER; // the case belongs to this space
      def.auto_release          = 0;                    // a unit force may point outward
      def.use_static_correction = 1;
      double extent             = 1.0;
      for (int d = 0; d < 3; ++d)
        extent = std::max({extent, std::fabs(basis.bounds_min[d]), std::fabs(basis.bounds_max[d])});
      def.workspace_radius = 2.0 * extent;
      return def;
    }
  } // namespace

  void verify_case(const modalrt_basis &basis, std::uint32_t index, modalrt_verify_case &result)
  {
    std::uint32_t space = 0, local = index;
    while (space < basis.space_count() && local >= basis.spaces[space].validation_count)
      local -= basis.spaces[space++].validation_count;
    if (space == basis.space_count())
      fail(MODALRT_ERROR_INVALID_ARGUMENT, cat("validation case ", index, " does not exist (the basis has ",
                                               index - local, ")"));
    const ModalSpace   &s         = basis.spaces[space];
    const std::uint32_t vertex    = s.validation_cases[2 * local];
    const std::uint32_t direction = s.validation_cases[2 * local + 1];

    modalrt_kernel    kernel(basis, verification_def(basis, space));
    modalrt_hip_input input{};
    std::copy_n(&basis.vertices[3 * std::size_t(vertex)], 3, input.position);
    input.force[direction] = 1.0;
    modalrt_hip_output output{};
    if (kernel.contact_begin(0, vertex) != MODALRT_OK || kernel.settle(&input, 1) != MODALRT_OK ||
        kernel.tick(&input, 1, &output, false) != MODALRT_OK)
      fail(MODALRT_ERROR_STATE, cat("the kernel refused validation case ", index));

    result.space        = space;
    result.vertex       = vertex;
    result.direction    = direction;
    result.is_candidate = s.candidate_index(vertex) >= 0 ? 1 : 0;
    double error = 0.0, size = 0.0;
    for (int d = 0; d < 3; ++d)
      {
        result.kernel[d]    = output.position[d] - input.position[d];
        result.reference[d] = s.validation_response[3 * std::size_t(local) + d];
        error += (result.kernel[d] - result.reference[d]) * (result.kernel[d] - result.reference[d]);
        size += result.reference[d] * result.reference[d];
      }
    // Relative to the reference; absolute for a zero reference (a clamped vertex).
    result.relative_error = std::sqrt(error) / (size > 0.0 ? std::sqrt(size) : 1.0);
  }

  int verify(const modalrt_basis &basis, modalrt_verify_report &report)
  {
    report           = modalrt_verify_report{};
    report.tolerance = basis.float64_modes() ? 1e-8 : 1e-5;
    for (const ModalSpace &s : basis.spaces)
      report.case_count += s.validation_count;
    for (std::uint32_t k = 0; k < report.case_count; ++k)
      {
        modalrt_verify_case c;
        verify_case(basis, k, c);
        if (!(c.relative_error <= report.max_relative_error) || k == 0)
          {
            report.max_relative_error = c.relative_error;
            report.worst_case         = k;
          }
      }
    return report.max_relative_error <= report.tolerance ? MODALRT_OK : MODALRT_ERROR_VERIFY_FAILED;
  }
} // namespace modalrt
