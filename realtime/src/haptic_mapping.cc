// The haptic mapping at the hand (haptic_mapping.h): the definition in the part's units, the
// sampled-passivity check, the change of units, and the ticks in the device's units around the
// kernel's ticks in the part's (kernel.cc).
#include "haptic_mapping.h"

#include "error.h"
#include "kernel.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>

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

// =================================================================================================
// The ticks in the device's units
// =================================================================================================
int modalrt_kernel::tick(const modalrt_hip_input *inputs, std::uint32_t count, modalrt_hip_output *outputs,
                         bool impedance) noexcept
{
  const int status = tick_in_part_units(mapping_.to_part(inputs, count), count, outputs, impedance);
  if (status < 0)
    return status;
  const std::uint32_t n = std::min(count, def.hip_capacity);
  mapping_.to_device(outputs, n);
  if (status == MODALRT_OK && impedance)
    render_at_hand(inputs, n, outputs);
  else
    passivity_.skip();
  return status;
}

int modalrt_kernel::tick_missing(std::uint32_t count, modalrt_hip_output *outputs) noexcept
{
  const int status = tick_missing_in_part_units(count, outputs);
  if (status >= 0)
    mapping_.to_device(outputs, count);
  passivity_.skip();
  return status;
}

// What the device renders: the stable-stiffness limit (with a scale), the passivity controller,
// the force limit; then the kernel's record of the force commanded follows what was sent, so that
// a ramp of its own (a release) starts from it.
void modalrt_kernel::render_at_hand(const modalrt_hip_input *inputs, std::uint32_t count,
                                    modalrt_hip_output *outputs) noexcept
{
  for (std::uint32_t h = 0; h < count && mapping_.scaled(); ++h)
    if (outputs[h].in_contact)
      limit_to_stable_stiffness(h, outputs[h]);
  // While the part's frame moves (a carried part), the session moves the part and the hands with it:
  // that energy is the carry's, not the coupling's, and the observer cannot tell the two apart, so
  // it watches only the periods of a still frame (the controller would otherwise damp the carry).
  if (frame_.moving)
    passivity_.skip();
  else
    passivity_.control(inputs, outputs, count, stats);
  for (std::uint32_t h = 0; h < count; ++h)
    {
      double *F = outputs[h].force;
      const double size = norm3(F);
      if (size > mapping_.max_force())
        {
          for (int d = 0; d < 3; ++d)
            F[d] *= mapping_.max_force() / size;
          outputs[h].flags |= MODALRT_HIP_FORCE_CLAMPED;
        }
      if (outputs[h].flags & MODALRT_HIP_BEYOND_RANGE)
        ++stats.beyond_range_ticks;
      mapping_.force_to_part(F, &commanded_[3 * std::size_t(h)]);
      std::copy_n(&commanded_[3 * std::size_t(h)], 3, last_outputs_[h].force);
    }
}

// The force along the contact's outward normal is at most device.max_stiffness x the hand's travel
// into the surface at rest (device units): a part stiffer than the band is a wall at the device's
// stable stiffness.
void modalrt_kernel::limit_to_stable_stiffness(std::uint32_t hip, modalrt_hip_output &out) noexcept
{
  const Contact &c = contacts_[hip];
  double         offset[3], n[3];
  for (int d = 0; d < 3; ++d)
    offset[d] = body_inputs_[hip].x[d] - c.rest[d];
  rotate(frame_.rotation, c.normal, n);
  const double travel = std::max(0.0, -dot3(offset, c.normal)) / mapping_.position_scale();
  const double along  = dot3(out.force, n), limit = mapping_.stable_stiffness() * travel;
  if (along <= limit)
    return;
  for (int d = 0; d < 3; ++d)
    out.force[d] -= (along - limit) * n[d];
  out.flags |= MODALRT_HIP_BEYOND_RANGE;
}

// The coupling spring of a contact (body frame). With a haptic scale, a snap contact's is stiff along
// the contact's normal only (coupling_stiffness, the part's units) and 1 % of the band's top stiffness
// across it: a spring as stiff in every direction would pin the contact point sideways, where the part moves
// as it bends, and the hand would feel the laterally held part, stiffer than the part pressed straight
// in (by 8 % on the tests' lattice). A sliding contact (its friction holds it sideways) and a kernel
// without a scale: coupling_stiffness in every direction.
void modalrt_kernel::set_contact_stiffness(Contact &c) const noexcept
{
  constexpr double lateral_share = 0.01; // across the normal: 1 % of the band's top
  const double K      = def.coupling_stiffness;
  const bool   normal = mapping_.scaled() && !c.proxy.active;
  const double across = normal ? lateral_share * mapping_.stable_stiffness() / mapping_.haptic_scale() : K;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c.stiffness[3 * i + j] = (i == j ? across : 0.0) + (normal ? (K - across) * c.normal[i] * c.normal[j] : 0.0);
}
