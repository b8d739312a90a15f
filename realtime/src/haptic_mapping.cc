// The haptic mapping at the hand (haptic_mapping.h): the definition in the part's units, the
// sampled-passivity check and the change of units. The kernel's ticks in the device's units, which
// use it, are in hand_rendering.cc.
#include "haptic_mapping.h"

#include "error.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>
#include <string>

using namespace modalrt;

namespace
{
  void require(bool condition, int status, const std::string &message)
  {
    if (!condition)
      fail(status, "kernel definition: " + message);
  }

  double workspace_sigma(const modalrt_kernel_def &d) { return d.workspace_scale == 0.0 ? 1.0 : d.workspace_scale; }

  void check_mapping_fields(const modalrt_kernel_def &d)
  {
    const double s = d.haptic_scale, sigma = d.workspace_scale;
    require(std::isfinite(s) && s >= 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("haptic_scale = ", s, ", expected 0 (no scale) or > 0"));
    require(std::isfinite(sigma) && sigma >= 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("workspace_scale = ", sigma, " m/m, expected > 0 (0: 1)"));
    require(finite3(d.workspace_origin), MODALRT_ERROR_INVALID_ARGUMENT, "workspace_origin must be finite");
    require(s > 0.0 || workspace_sigma(d) == 1.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("workspace_scale = ", sigma, " needs a haptic_scale (the force is scaled with the positions)"));
    require(s == 0.0 || d.device.kind == MODALRT_DEVICE_IMPEDANCE, MODALRT_ERROR_INVALID_ARGUMENT,
            "haptic_scale applies to impedance devices: an admittance device renders the part's stiffness as it is");
    require(d.device.kind <= MODALRT_DEVICE_ADMITTANCE, MODALRT_ERROR_INVALID_ARGUMENT, "unknown device.kind");
    require(std::isfinite(d.coupling_multiple) && (d.coupling_multiple == 0.0 || d.coupling_multiple >= 10.0),
            MODALRT_ERROR_INVALID_ARGUMENT, cat("coupling_multiple = ", d.coupling_multiple, ", expected >= 10 (0: 200)"));
    require(d.passivity_control <= 1, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("passivity_control = ", d.passivity_control, ", expected 0 or 1"));
    require(s == 0.0 || (std::isfinite(d.device.max_stiffness) && d.device.max_stiffness > 0.0),
            MODALRT_ERROR_INVALID_ARGUMENT, "haptic_scale needs device.max_stiffness > 0 (the band's top at the hand)");
  }
} // namespace

namespace modalrt
{
  modalrt_kernel_def part_side_def(const modalrt_kernel_def &d)
  {
    check_mapping_fields(d);
    modalrt_kernel_def part = d;
    if (d.haptic_scale == 0.0)
      return part;
    const double s = d.haptic_scale, sigma = workspace_sigma(d);
    const double multiple      = d.coupling_multiple == 0.0 ? default_coupling_multiple : d.coupling_multiple;
    part.coupling_stiffness    = multiple * d.device.max_stiffness / s;
    part.coupling_damping      = d.coupling_damping / s; // s x it at the hand
    part.device.max_stiffness  = part.coupling_stiffness;
    part.device.max_damping    = std::max(d.device.max_damping / s, part.coupling_damping);
    part.device.max_force      = d.device.max_force * sigma / s;
    part.force_rate_limit      = d.force_rate_limit * sigma / s;
    part.device.physical_damping = d.device.physical_damping / s;
    return part;
  }

  void check_sampled_passivity(const modalrt_kernel_def &d)
  {
    if (d.device.kind != MODALRT_DEVICE_IMPEDANCE || d.passivity_control)
      return;
    const double b = d.device.physical_damping, T = d.time_step, B = std::fabs(d.coupling_damping);
    const double K = d.haptic_scale > 0.0 ? d.device.max_stiffness : d.coupling_stiffness;
    require(b > K * T / 2.0 + B, MODALRT_ERROR_DEVICE_LIMIT,
            cat("not passive (Colgate & Schenkel: b > K T / 2 + |B|): b = ", b, " N s/m, K = ", K, " N/m, T = ", T,
                " s, B = ", B, " N s/m give K T / 2 + |B| = ", K * T / 2.0 + B,
                " N s/m; lower K or B, or set passivity_control = 1"));
  }

  void HapticMapping::setup(const modalrt_kernel_def &d, const modalrt_kernel_def &part, std::uint32_t hips)
  {
    scale_            = d.haptic_scale;
    sigma_            = workspace_sigma(d);
    force_scale_      = (scale_ > 0.0 ? scale_ : 1.0) / sigma_;
    std::copy_n(d.workspace_origin, 3, origin_);
    identity_         = force_scale_ == 1.0 && sigma_ == 1.0 && origin_[0] == 0.0 && origin_[1] == 0.0 && origin_[2] == 0.0;
    stable_stiffness_ = d.device.max_stiffness;
    max_force_        = d.device.max_force;
    inputs_.assign(identity_ ? 0 : hips, modalrt_hip_input{});
    (void)part;
  }

  void HapticMapping::describe(modalrt_haptic_mapping &out, const modalrt_kernel_def &part) const
  {
    out                   = modalrt_haptic_mapping{};
    out.haptic_scale      = scale_ > 0.0 ? scale_ : 1.0;
    out.workspace_scale   = sigma_;
    std::copy_n(origin_, 3, out.workspace_origin);
    out.force_scale             = force_scale_;
    out.part_coupling_stiffness = part.coupling_stiffness;
    out.part_coupling_damping   = part.coupling_damping;
    if (scale_ > 0.0)
      {
        out.band_top_stiffness = stable_stiffness_ / scale_;
        out.series_share       = out.band_top_stiffness / (out.band_top_stiffness + part.coupling_stiffness);
      }
  }

  const modalrt_hip_input *HapticMapping::to_part(const modalrt_hip_input *inputs, std::uint32_t count) noexcept
  {
    if (identity_ || !inputs || count > inputs_.size())
      return inputs;
    for (std::uint32_t h = 0; h < count; ++h)
      for (int d = 0; d < 3; ++d)
        {
          inputs_[h].position[d] = origin_[d] + sigma_ * inputs[h].position[d];
          inputs_[h].velocity[d] = sigma_ * inputs[h].velocity[d];
          inputs_[h].force[d]    = inputs[h].force[d] / force_scale_;
        }
    return inputs_.data();
  }

  void HapticMapping::to_device(modalrt_hip_output *outputs, std::uint32_t count) const noexcept
  {
    if (identity_)
      return;
    for (std::uint32_t h = 0; h < count; ++h)
      for (int d = 0; d < 3; ++d)
        {
          outputs[h].position[d] = (outputs[h].position[d] - origin_[d]) / sigma_;
          outputs[h].velocity[d] /= sigma_;
          outputs[h].force[d] *= force_scale_;
        }
  }

  void HapticMapping::force_to_part(const double device[3], double part[3]) const noexcept
  {
    for (int d = 0; d < 3; ++d)
      part[d] = device[d] / force_scale_;
  }
} // namespace modalrt
