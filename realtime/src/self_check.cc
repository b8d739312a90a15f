// The self-check: the full-FE validation cases stored in the basis, replayed through the kernel.
// Each case is a unit force at a display vertex; the kernel is put at the exact static equilibrium
// under it (so no time is spent waiting for slow, lightly damped modes to settle), runs one
// admittance tick from there (a fixed point of the exact integrator, so the tick keeps it) and
// reports the felt displacement u_c, which must equal W_v^T K^-1 W_v e_dir. A free-floating space
// (rigid-body modes, omega = 0) has no static equilibrium under a force: there the case runs in the
// frame that follows the part's rigid acceleration (inertia relief), where the elastic state is
// static and must equal the precompute's inertia-relief answer.
#include "self_check.h"

#include "dense.h"
#include "error.h"
#include "kernel.h"
#include "vector3.h"

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
      def.workspace_radius       = 2.0 * extent;
      def.max_frame_acceleration = HUGE_VAL; // a unit force may accelerate a light free part a lot
      return def;
    }

    // The rigid motion (translation t, rotation w about the centre of mass) that rigid-body mode i is:
    // the least-squares fit of t + w x (x_v - c) to the mode at the display vertices (exact but for
    // the stored precision).
    void rigid_motion_of_mode(const modalrt_basis &basis, const ModalSpace &s, std::uint32_t i, double motion[6])
    {
      const std::uint32_t r = s.mode_count;
      double              normal[36] = {};
      std::fill_n(motion, 6, 0.0);
      for (std::uint32_t v = 0; v < basis.vertex_count; ++v)
        {
          double d[3];
          for (int c = 0; c < 3; ++c)
            d[c] = basis.vertices[3 * std::size_t(v) + c] - basis.centre_of_mass()[c];
          // Row c of A_v = [I, -[d]x]: (w x d)_c = -(d x w)_c.
          const double A[3][6] = {{1, 0, 0, 0, d[2], -d[1]}, {0, 1, 0, -d[2], 0, d[0]}, {0, 0, 1, d[1], -d[0], 0}};
          for (int c = 0; c < 3; ++c)
            {
              const std::size_t at = 3 * std::size_t(r) * v + std::size_t(c) * r + i;
              const double u = s.display_modes_f64.empty() ? double(s.display_modes_f32[at]) : s.display_modes_f64[at];
              for (int k = 0; k < 6; ++k)
                {
                  motion[k] += A[c][k] * u;
                  for (int l = 0; l < 6; ++l)
                    normal[6 * k + l] += A[c][k] * A[c][l];
                }
            }
        }
      if (!solve_in_place(normal, motion, 6))
        fail(MODALRT_ERROR_STATE, "the display surface cannot tell the rigid-body modes apart");
    }

    // The frame acceleration under which the rigid-body modes (lambda = 0) of the space feel no net
    // modal force from the force F at a candidate: with the frame's modal force -Gamma a (moving_frame.cc),
    // Gamma_R a = B_R^T F for the rows R of those modes. A free part's six: solved from the
    // participation factors. Fewer (supports hold the part partly): the modes are the free motions,
    // M-orthonormal, and the frame accelerates along them only, a = sum_m motion_m (B_m^T F) (the
    // constrained system's rigid mass, which Gamma_R holds, is not in the file). Identity frame when
    // the space has none.
    modalrt_frame_state inertia_relief_frame(const modalrt_basis &basis, const ModalSpace &s, int candidate,
                                             const double force[3])
    {
      modalrt_frame_state frame = modalrt_frame_state_identity();
      const std::uint32_t r = s.mode_count;
      std::uint32_t       n_rigid = 0;
      while (n_rigid < r && s.eigenvalues[n_rigid] == 0.0)
        ++n_rigid;
      if (n_rigid == 0)
        return frame;
      if (candidate < 0 || (n_rigid == 6 && s.participation.empty()))
        fail(MODALRT_ERROR_STATE, cat("a space with ", n_rigid, " rigid-body modes can only be verified at a candidate "
                                      "(with participation factors when there are six)"));
      const double *B = &s.candidate_modes[3 * std::size_t(r) * std::size_t(candidate)];
      double        body_acceleration[6] = {};
      if (n_rigid == 6)
        {
          double A[36];
          for (std::uint32_t i = 0; i < 6; ++i)
            {
              body_acceleration[i] = B[i] * force[0] + B[r + i] * force[1] + B[2 * r + i] * force[2];
              std::copy_n(&s.participation[6 * std::size_t(i)], 6, &A[6 * i]);
            }
          if (!solve_in_place(A, body_acceleration, 6))
            fail(MODALRT_ERROR_STATE, "the rigid-body modes' participation factors are singular");
        }
      else
        for (std::uint32_t i = 0; i < n_rigid; ++i)
          {
            double       motion[6];
            const double b = B[i] * force[0] + B[r + i] * force[1] + B[2 * r + i] * force[2];
            rigid_motion_of_mode(basis, s, i, motion);
            for (int k = 0; k < 6; ++k)
              body_acceleration[k] += motion[k] * b;
          }
      // The frame takes its origin's acceleration: a_origin = a_com - alpha x c.
      double alpha_c[3];
      cross3(&body_acceleration[3], basis.centre_of_mass(), alpha_c);
      for (int d = 0; d < 3; ++d)
        {
          frame.linear_acceleration[d]  = body_acceleration[d] - alpha_c[d];
          frame.angular_acceleration[d] = body_acceleration[3 + d];
        }
      return frame;
    }
  } // namespace

  void verify_case(const modalrt_basis &basis, std::uint32_t index, modalrt_verify_case &result)
  {
    std::uint32_t space = 0, local = index;
    while (space < basis.space_count() && local >= basis.spaces[space].validation_count)
      local -= basis.spaces[space++].validation_count;
    if (space == basis.space_count())
      fail(MODALRT_ERROR_INVALID_ARGUMENT, cat("modalrt_basis_verify_case: ", basis.source, ": validation case ",
                                               index, " does not exist (the basis has ", index - local, ")"));
    const ModalSpace   &s         = basis.spaces[space];
    const std::uint32_t vertex    = s.validation_cases[2 * local];
    const std::uint32_t direction = s.validation_cases[2 * local + 1];

    modalrt_kernel    kernel(basis, verification_def(basis, space));
    modalrt_hip_input input{};
    std::copy_n(&basis.vertices[3 * std::size_t(vertex)], 3, input.position);
    input.force[direction] = 1.0;
    modalrt_hip_output output{};
    if (kernel.set_frame(inertia_relief_frame(basis, s, s.candidate_index(vertex), input.force)) != MODALRT_OK ||
        kernel.contact_begin(0, vertex) != MODALRT_OK || kernel.settle(&input, 1) != MODALRT_OK ||
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
