// The haptic loop: creation, the tick and its admittance and impedance steps, the outputs, the
// switch of modal space (over space_switch.h) and the publication of display snapshots. Contacts
// live in contact.cc, the moving frame in moving_frame.h; modalrt.h states the rules as the user
// sees them.
#include "kernel.h"

#include "dense.h"
#include "space_switch.h"
#include "error.h"
#include "vector3.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

using namespace modalrt;

namespace
{
  // Moves `to` within `limit` of `from` (along the difference, so |to| stays within the larger of the
  // two magnitudes); true if it had to.
  bool limit_change(const double from[3], double to[3], double limit)
  {
    double change[3];
    for (int d = 0; d < 3; ++d)
      change[d] = to[d] - from[d];
    const double size = norm3(change);
    if (size <= limit)
      return false;
    for (int d = 0; d < 3; ++d)
      to[d] = from[d] + change[d] * (limit / size);
    return true;
  }

  // A flags_ bit of the kernel's own (never output): the contact's force would pull, release it.
  constexpr std::uint32_t would_pull = 1u << 31;

  std::uint64_t now_ns()
  {
    return std::uint64_t(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
  }

  // ----- the definition's checks (at create, with messages) ----------------------------------
  void require(bool condition, int status, const std::string &message)
  {
    if (!condition)
      fail(status, "kernel definition: " + message);
  }

  void check_device(const modalrt_kernel_def &d)
  {
    const modalrt_device_def &dev = d.device;
    require(std::isfinite(dev.max_force) && dev.max_force > 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("device.max_force = ", dev.max_force, " N must be finite and > 0"));
    require(std::isfinite(dev.max_stiffness) && dev.max_stiffness >= 0.0 && std::isfinite(dev.max_damping) &&
              dev.max_damping >= 0.0 && std::isfinite(dev.physical_damping) && dev.physical_damping >= 0.0,
            MODALRT_ERROR_INVALID_ARGUMENT, "device stiffness and damping limits must be finite and >= 0");
    const double K = d.coupling_stiffness, D = d.coupling_damping;
    require(std::isfinite(K) && K >= 0.0 && std::isfinite(D) && D >= 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            "coupling_stiffness and coupling_damping must be finite and >= 0");
    require(K <= dev.max_stiffness, MODALRT_ERROR_DEVICE_LIMIT,
            cat("coupling_stiffness ", K, " N/m exceeds the device's max_stiffness ", dev.max_stiffness, " N/m"));
    require(D <= dev.max_damping, MODALRT_ERROR_DEVICE_LIMIT,
            cat("coupling_damping ", D, " N s/m exceeds the device's max_damping ", dev.max_damping, " N s/m"));
    // Sampled passivity: check_sampled_passivity (haptic_mapping.cc), on the device's definition.
  }

  void check_definition(const modalrt_basis &basis, const modalrt_kernel_def &d)
  {
    require(std::isfinite(d.time_step) && d.time_step >= 1e-6 && d.time_step <= 1.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("time_step = ", d.time_step, " s, expected 1e-6 .. 1"));
    require(d.hip_capacity >= 1 && d.hip_capacity <= max_hip_capacity, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("hip_capacity = ", d.hip_capacity, ", expected 1 .. ", max_hip_capacity));
    require(d.initial_space < basis.space_count(), MODALRT_ERROR_INVALID_ARGUMENT,
            cat("initial_space = ", d.initial_space, ", the basis has ", basis.space_count(), " spaces"));
    check_device(d);
    require(std::isfinite(d.snap_distance) && d.snap_distance > 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            "snap_distance must be finite and > 0");
    require(std::isfinite(d.contact_tolerance) && std::isfinite(d.release_distance) && d.release_distance >= 0.0 &&
              std::isfinite(d.release_force) && d.release_force >= 0.0,
            MODALRT_ERROR_INVALID_ARGUMENT, "contact_tolerance, release_distance and release_force must be finite "
                                            "(the last two >= 0)");
    require(d.max_input_force > 0.0 && d.workspace_radius > 0.0 && d.max_input_velocity > 0.0 &&
              d.max_frame_acceleration > 0.0,
            MODALRT_ERROR_INVALID_ARGUMENT,
            "max_input_force, workspace_radius, max_input_velocity and max_frame_acceleration must be > 0");
    require(d.snap_candidate_budget >= 1 && d.snap_candidate_budget <= 256, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("snap_candidate_budget = ", d.snap_candidate_budget, ", expected 1 .. 256"));
    require(d.switch_rule <= MODALRT_SWITCH_NEVER, MODALRT_ERROR_INVALID_ARGUMENT, "unknown switch_rule");
    require(d.snapshot_interval >= 1, MODALRT_ERROR_INVALID_ARGUMENT, "snapshot_interval must be >= 1");
    require(d.validity_level == 0 || validity_level_index(d.validity_level) >= 0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("validity_level = ", d.validity_level, " %, expected 1, 5 or 10 (0: the default 5)"));
    require(std::isfinite(d.release_drag_distance) && d.release_drag_distance > 0.0, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("release_drag_distance = ", d.release_drag_distance, " m must be finite and > 0"));
    require(std::isfinite(d.fail_safe_hold) && d.fail_safe_hold >= 0.0 && d.fail_safe_hold <= 10.0,
            MODALRT_ERROR_INVALID_ARGUMENT, cat("fail_safe_hold = ", d.fail_safe_hold, " s, expected 0 .. 10"));
    require(std::isfinite(d.fail_safe_ramp) && d.fail_safe_ramp > 0.0 && d.fail_safe_ramp <= 10.0,
            MODALRT_ERROR_INVALID_ARGUMENT,
            cat("fail_safe_ramp = ", d.fail_safe_ramp, " s, expected > 0 and <= 10: the force must ramp to zero, "
                "never step"));
    require(std::isfinite(d.force_rate_limit) && d.force_rate_limit > 0.0 && d.force_rate_limit <= d.device.max_force,
            MODALRT_ERROR_INVALID_ARGUMENT,
            cat("force_rate_limit = ", d.force_rate_limit, " N per tick, expected > 0 and <= device.max_force (",
                d.device.max_force, " N)"));
    require(d.grasp <= 1, MODALRT_ERROR_INVALID_ARGUMENT, cat("grasp = ", d.grasp, ", expected 0 or 1"));
    require(d.validity_clamp <= 1, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("validity_clamp = ", d.validity_clamp, ", expected 0 or 1"));
    require(d.contact_mode <= MODALRT_CONTACT_PROXY, MODALRT_ERROR_INVALID_ARGUMENT,
            cat("contact_mode = ", d.contact_mode, " (expected MODALRT_CONTACT_SNAP or _PROXY)"));
    require(std::isfinite(d.static_friction) && d.dynamic_friction >= 0.0 && d.dynamic_friction <= d.static_friction &&
              d.static_friction <= 10.0,
            MODALRT_ERROR_INVALID_ARGUMENT,
            cat("static_friction = ", d.static_friction, ", dynamic_friction = ", d.dynamic_friction,
                ": expected 0 <= dynamic_friction <= static_friction <= 10"));
  }
} // namespace

// =================================================================================================
// Creation (allocates everything the loop will use)
// =================================================================================================
modalrt_kernel::modalrt_kernel(const modalrt_basis &basis_, const modalrt_kernel_def &def_)
  : basis(basis_)
  , def(part_side_def(def_))
{
  check_definition(basis, def);
  check_sampled_passivity(def_);
  const std::uint32_t R = basis.max_modes, H = def.hip_capacity;
  integrators_.resize(basis.space_count());
  for (std::uint32_t s = 0; s < basis.space_count(); ++s)
    {
      const ModalSpace &space = basis.spaces[s];
      integrators_[s].setup(space.eigenvalues.data(), space.damping_ratios.data(), space.mode_count, def.time_step);
    }
  for (modalrt::Vector<double> *buffer : {&q_, &v_, &f_, &q_free_, &v_free_, &transfer_scratch_})
    buffer->assign(R, 0.0);
  rows_.assign(std::size_t(H) * 3 * R, 0.0);
  contacts_.resize(H);
  for (std::uint32_t h = 0; h < H; ++h)
    contacts_[h].B = rows_.data() + std::size_t(h) * 3 * R;
  body_inputs_.resize(H);
  flags_.assign(H, 0);
  last_outputs_.assign(H, modalrt_hip_output{});
  for (modalrt_hip_output &o : last_outputs_)
    o.active_vertex = o.proxy_triangle = MODALRT_NONE;
  commanded_.assign(3 * std::size_t(H), 0.0);
  ramping_.assign(H, 0);
  active_.assign(H, 0);
  for (modalrt::Vector<double> *m : {&compliance_, &coupling_, &coupling_velocity_, &system_})
    m->assign(9 * std::size_t(H) * H, 0.0);
  rhs_.assign(3 * std::size_t(H), 0.0);
  snap_search_.setup(def.snap_candidate_budget);
  // A sliding contact's row slots and their pair blocks (proxy_state.h): the corners of its
  // triangle and the rows prepared ahead of it.
  proxy_rows_.assign(def.contact_mode == MODALRT_CONTACT_PROXY ? std::size_t(H) * proxy_row_slots * 3 * R : 0, 0.0);
  proxy_grams_.resize(def.contact_mode == MODALRT_CONTACT_PROXY ? std::size_t(H) * proxy_slot_pairs : 0);
  for (std::uint32_t h = 0; h < H && !proxy_rows_.empty(); ++h)
    {
      for (std::uint32_t k = 0; k < proxy_row_slots; ++k)
        contacts_[h].proxy.rows[k].buffer = proxy_rows_.data() + (std::size_t(h) * proxy_row_slots + k) * 3 * R;
      contacts_[h].proxy.grams = proxy_grams_.data() + std::size_t(h) * proxy_slot_pairs;
    }
  if (def.contact_mode == MODALRT_CONTACT_PROXY)
    stored_proxy_rows_.make(basis, integrators_,
                            def.proxy_row_memory == MODALRT_PROXY_ROWS_IN_TICKS ? 0
                            : std::size_t(def.proxy_row_memory == 0 ? proxy_default_row_memory_mib
                                                                    : def.proxy_row_memory)
                                << 20);
  observed_positions_.assign(3 * std::size_t(H), 0.0);
  snapshots.allocate(R, H);
  space_              = def.initial_space;
  stats.active_space  = space_;
  // The fail-safe rule in whole ticks (no rounding drift between the hold and the ramp); the ramp
  // lasts at least two ticks, so the force never steps to zero.
  hold_ticks_ = std::uint64_t(std::llround(def.fail_safe_hold / def.time_step));
  ramp_ticks_ = std::max<std::uint64_t>(2, std::uint64_t(std::llround(def.fail_safe_ramp / def.time_step)));
  validity_level_ = validity_level_index(def.validity_level == 0 ? 5 : def.validity_level);
  mapping_.setup(def_, def, H);
  passivity_.setup(def_.passivity_control != 0, def.time_step, def_.device.max_damping, H);
  // The plane at the stiffness the device renders stably (a scale), else at the coupling's.
  const double plane_at_hand = mapping_.scaled() ? mapping_.stable_stiffness() : def_.coupling_stiffness;
  fail_safe_plane_.setup(H, mapping_.stiffness_to_part(plane_at_hand), def.force_rate_limit, def.time_step);
}

// =================================================================================================
// The tick
// =================================================================================================
int modalrt_kernel::tick_in_part_units(const modalrt_hip_input *inputs, std::uint32_t count,
                                       modalrt_hip_output *outputs, bool impedance) noexcept
{
  if ((count > 0 && (!inputs || !outputs)))
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_tick: null inputs or outputs with count > 0");
  const std::uint64_t start = def.enable_profile ? now_ns() : 0;
  ++stats.tick_count;

  if (const std::uint32_t reasons = validate(inputs, count, impedance))
    {
      ++stats.rejected_ticks;
      stats.last_reject_reasons = reasons;
      return fail_safe(std::min(count, def.hip_capacity), outputs, count <= def.hip_capacity ? inputs : nullptr);
    }
  if (stats.fail_safe_run > 0) // the recovery after a fault: the force returns at the rate limit
    std::fill(ramping_.begin(), ramping_.end(), 1u);
  stats.fail_safe_run = 0;

  std::fill(flags_.begin(), flags_.end(), 0u);
  to_body(inputs, count);
  fail_safe_plane_.remember(inputs, count, impedance);
  apply_release_rules(count, impedance);
  detect_contacts(count);
  if (impedance)
    slide_proxies(count);
  apply_switch_rule();
  if (impedance)
    impedance_step();
  else
    admittance_step();
  observe_passivity(impedance ? inputs : nullptr, count);
  write_outputs(count, outputs, impedance);
  stats.time += def.time_step;
  publish_snapshot();

  if (def.enable_profile)
    {
      stats.last_tick_seconds = 1e-9 * double(now_ns() - start);
      stats.max_tick_seconds  = std::max(stats.max_tick_seconds, stats.last_tick_seconds);
    }
  return MODALRT_OK;
}

int modalrt_kernel::tick_missing_in_part_units(std::uint32_t count, modalrt_hip_output *outputs) noexcept
{
  if (count > def.hip_capacity || (count > 0 && !outputs))
    return failed(MODALRT_ERROR_INVALID_ARGUMENT,
                  "modalrt_kernel_tick_missing: count above hip_capacity, or null outputs with count > 0");
  ++stats.tick_count;
  ++stats.missing_ticks;
  stats.last_reject_reasons = MODALRT_REJECT_MISSING;
  return fail_safe(count, outputs);
}

// The state does not move; the device gets the last outputs that were safe, flagged, with their
// force held for fail_safe_hold and then ramped linearly to zero over fail_safe_ramp, and in
// impedance at most the share of it that the fail-safe plane gives the hand (fail_safe_plane.h).
int modalrt_kernel::fail_safe(std::uint32_t count, modalrt_hip_output *outputs, const modalrt_hip_input *inputs) noexcept
{
  ++stats.fail_safe_ticks;
  ++stats.fail_safe_run;
  observed_count_ = 0; // the passivity observer skips the period after a fail-safe tick
  const std::uint64_t n     = stats.fail_safe_run;
  const double        scale = n <= hold_ticks_ ? 1.0 : std::max(0.0, 1.0 - double(n - hold_ticks_) / double(ramp_ticks_));
  if (n == 1)
    fail_safe_plane_.begin_run();
  bool held_force = false;
  for (std::uint32_t h = 0; h < count; ++h)
    {
      held_force = held_force || norm3(last_outputs_[h].force) > 0.0;
      outputs[h] = last_outputs_[h];
      // A hand whose own position is absurd is not where it says: its plane takes it as unknown.
      const bool   trusted = inputs && finite3(inputs[h].position) && norm3(inputs[h].position) <= def.workspace_radius;
      const double share   = fail_safe_plane_.share(h, last_outputs_[h].force, trusted ? inputs[h].position : nullptr, n);
      for (int d = 0; d < 3; ++d)
        outputs[h].force[d] *= std::min(scale, share);
      outputs[h].flags = MODALRT_HIP_FAIL_SAFE;
      if (outputs[h].in_contact && beyond_validity(contacts_[h], outputs[h].force))
        outputs[h].flags |= MODALRT_HIP_BEYOND_VALIDITY; // the force held is still beyond it
      std::copy_n(outputs[h].force, 3, &commanded_[3 * std::size_t(h)]);
    }
  if (scale < 1.0 && held_force)
    ++stats.dropout_ticks;
  return MODALRT_INPUT_REJECTED;
}

// Every device input is checked before anything moves.
std::uint32_t modalrt_kernel::validate(const modalrt_hip_input *inputs, std::uint32_t count, bool impedance) const noexcept
{
  if (count > def.hip_capacity)
    return MODALRT_REJECT_HIP_COUNT;
  std::uint32_t reasons = 0;
  for (std::uint32_t h = 0; h < count; ++h)
    {
      const modalrt_hip_input &in = inputs[h];
      if (!finite3(in.position) || !finite3(in.velocity) || (!impedance && !finite3(in.force)))
        {
          reasons |= MODALRT_REJECT_NOT_FINITE;
          continue;
        }
      if (norm3(in.position) > def.workspace_radius)
        reasons |= MODALRT_REJECT_POSITION;
      if (norm3(in.velocity) > def.max_input_velocity)
        reasons |= MODALRT_REJECT_VELOCITY;
      if (!impedance && norm3(in.force) > def.max_input_force)
        reasons |= MODALRT_REJECT_FORCE;
    }
  return reasons;
}

// Admittance: the forces are given; the modes move; the active vertices report where they are.
void modalrt_kernel::admittance_step() noexcept
{
  refresh_contact_set();
  for (std::uint32_t k = 0; k < active_count_; ++k)
    std::copy_n(body_inputs_[active_[k]].force, 3, contacts_[active_[k]].force);
  frame_modal_force(f_.data());
  add_contact_forces(f_.data());
  integrators_[space_].step(q_.data(), v_.data(), f_.data());
  ++state_stamp_;
  update_corrections();
}

// Impedance: the coupling force and the modal step are solved together. With the free step
// (q_f, v_f) (no contact force) and the per-tick gains G = diag(g1), H = diag(g2), the felt
// displacement and velocity after the tick are linear in the coupling forces F:
//     x_a = rest_a + B_a q_f + sum_b (B_a G B_b^T + C_ab) F_b,    v_a = B_a v_f + sum_b B_a H B_b^T F_b
// and F_a = K (x_hip,a - x_a) + D (v_hip,a - v_a) gives a 3n x 3n linear system.
void modalrt_kernel::impedance_step() noexcept
{
  refresh_contact_set();
  if (coupling_dirty_)
    refresh_coupling_matrices();
  const ModalIntegrator &integrator = integrators_[space_];
  const std::uint32_t    r          = integrator.mode_count();
  frame_modal_force(f_.data());
  integrator.step_to(q_.data(), v_.data(), f_.data(), q_free_.data(), v_free_.data());

  const std::uint32_t n = active_count_, n3 = 3 * n;
  const double        D = def.coupling_damping;
  for (std::uint32_t a = 0; a < n; ++a)
    {
      const Contact   &c  = contacts_[active_[a]];
      const BodyInput &in = body_inputs_[active_[a]];
      double           xp[3], vp[3], gap[3];
      dot_rows3_pair(c.B, q_free_.data(), v_free_.data(), r, xp, vp);
      for (int d = 0; d < 3; ++d)
        gap[d] = in.x[d] - c.rest[d] - c.anchor[d] - xp[d];
      for (int d = 0; d < 3; ++d)
        rhs_[3 * a + d] = dot3(&c.stiffness[3 * d], gap) + D * (in.v[d] - vp[d]);
    }
  // Row i of contact a: K_a (its 3 x 3 coupling stiffness, contact_stiffness) times the coupling rows.
  for (std::uint32_t i = 0; i < n3; ++i)
    for (std::uint32_t j = 0; j < n3; ++j)
      {
        const double *K = &contacts_[active_[i / 3]].stiffness[3 * (i % 3)];
        const std::uint32_t first = i - i % 3;
        double       KC = 0.0;
        for (std::uint32_t k = 0; k < 3; ++k)
          KC += K[k] * coupling_[(first + k) * n3 + j];
        system_[i * n3 + j] = (i == j ? 1.0 : 0.0) + KC + D * coupling_velocity_[i * n3 + j];
      }
  solve_coupling(n3);

  for (std::uint32_t a = 0; a < n; ++a)
    {
      double      *F     = &rhs_[3 * a];
      if (contacts_[active_[a]].proxy.active) // Coulomb's cone first: the clamps below scale F and keep it
        hold_in_friction_cone(contacts_[active_[a]], F);
      const double size  = norm3(F);
      const double limit = def.device.max_force;
      if (size > limit)
        {
          for (int d = 0; d < 3; ++d)
            F[d] *= limit / size;
          flags_[active_[a]] |= MODALRT_HIP_FORCE_CLAMPED;
          ++stats.clamped_forces;
        }
      if (def.validity_clamp)
        clamp_to_validity(contacts_[active_[a]], F);
      std::copy_n(F, 3, contacts_[active_[a]].force);
      if (!def.grasp && dot3(F, contacts_[active_[a]].normal) > 0.0)
        {
          flags_[active_[a]] |= would_pull; // released after this step, without a force on the part
          std::fill_n(contacts_[active_[a]].force, 3, 0.0);
        }
      else if (ramping_[active_[a]])
        limit_contact_force(active_[a]);
    }

  std::fill_n(f_.data(), r, 0.0);
  add_contact_forces(f_.data());
  const double *g1 = integrator.g1(), *g2 = integrator.g2();
  for (std::uint32_t i = 0; i < r; ++i)
    {
      q_[i] = flush(q_free_[i] + g1[i] * f_[i]);
      v_[i] = flush(v_free_[i] + g2[i] * f_[i]);
    }
  ++state_stamp_;
  update_corrections();
  release_pulling_contacts();
}

// The force on the part of ramping contact `hip` moves by at most force_rate_limit from the force last
// commanded on its device (world, the opposite of the force on the part).
void modalrt_kernel::limit_contact_force(std::uint32_t hip) noexcept
{
  double *F = contacts_[hip].force, target[3], pushed[3];
  rotate(frame_.rotation, F, pushed);
  for (int d = 0; d < 3; ++d)
    target[d] = -pushed[d];
  if (!limit_change(&commanded_[3 * std::size_t(hip)], target, def.force_rate_limit))
    {
      ramping_[hip] = 0; // caught up: the coupling's force from here on
      return;
    }
  flags_[hip] |= MODALRT_HIP_FORCE_RAMPING;
  for (int d = 0; d < 3; ++d)
    target[d] = -target[d];
  rotate_back(frame_.rotation, target, F);
}

// The validity force of a contact in the active space at def.validity_level: its vertex's, a proxy's
// blend over its triangle's corners (blended_validity_force); 0 where the map has no value.
double modalrt_kernel::contact_validity_force(const Contact &c) const noexcept
{
  const ModalSpace &space = basis.spaces[space_];
  if (space.validity_force.empty())
    return 0.0;
  if (c.proxy.active)
    return blended_validity_force(space, &basis.triangles[3 * std::size_t(c.proxy.triangle)], c.proxy.weights, 3,
                                  validity_level_);
  const double one = 1.0;
  return blended_validity_force(space, &c.vertex, &one, 1, validity_level_);
}

// validity_clamp: the force on the part (and so the one commanded) is limited in magnitude to the
// contact's validity force. The limit follows that force at most force_rate_limit per tick (a proxy
// entering a region of another value, a switch of space, the map ending), so the clamp itself never
// makes a step of the kernel's own; where the map has no value the limit rises towards
// device.max_force. It starts at the contact's value when the contact begins.
void modalrt_kernel::clamp_to_validity(Contact &c, double F[3]) noexcept
{
  const double value  = contact_validity_force(c);
  const double target = value > 0.0 ? std::min(value, def.device.max_force) : def.device.max_force;
  if (c.validity_limit < 0.0)
    c.validity_limit = target;
  else
    c.validity_limit += std::max(-def.force_rate_limit, std::min(def.force_rate_limit, target - c.validity_limit));
  const double size = norm3(F);
  if (size <= c.validity_limit)
    return;
  c.validity_unclamped = size;
  for (int d = 0; d < 3; ++d)
    F[d] *= c.validity_limit / size;
}

// Whether a contact's force is beyond its validity force (this tick's, c.validity_force): |force|, or
// the force before validity_clamp when force is null (the clamp acted), above a value of the map.
bool modalrt_kernel::beyond_validity(const Contact &c, const double force[3]) const noexcept
{
  const double size = force ? norm3(force) : c.validity_unclamped;
  return c.validity_force > 0.0 && size > c.validity_force;
}

// Released HIPs (and HIPs absent from the tick): the commanded force ramps to zero.
void modalrt_kernel::ramp_released_force(std::uint32_t hip, double force_world[3]) noexcept
{
  std::fill_n(force_world, 3, 0.0);
  if (!ramping_[hip])
    return;
  if (limit_change(&commanded_[3 * std::size_t(hip)], force_world, def.force_rate_limit))
    flags_[hip] |= MODALRT_HIP_FORCE_RAMPING;
  else
    ramping_[hip] = 0;
}

// Contacts whose coupling force would have pulled (marked by impedance_step, their force on the part
// already zero) end after the step: a surface pushes, it does not stick (unless def.grasp).
void modalrt_kernel::release_pulling_contacts() noexcept
{
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    if (flags_[h] & would_pull)
      {
        flags_[h] = (flags_[h] & ~would_pull) | MODALRT_HIP_RELEASED;
        end_contact(h);
      }
}

// The static correction of each contact: sum_b C_ab F_b.
void modalrt_kernel::update_corrections() noexcept
{
  const std::uint32_t n3 = 3 * active_count_;
  for (std::uint32_t a = 0; a < active_count_; ++a)
    {
      double *corr = contacts_[active_[a]].correction;
      for (int c = 0; c < 3; ++c)
        {
          double sum = 0.0;
          for (std::uint32_t b = 0; b < active_count_; ++b)
            for (int d = 0; d < 3; ++d)
              sum += compliance_[(3 * a + c) * n3 + 3 * b + d] * contacts_[active_[b]].force[d];
          corr[c] = sum;
        }
    }
}

// The coupling system_ (n x n) with right-hand side rhs_ (solution written over it). A vanishing
// pivot (not met with a passive coupling) falls back to the explicit coupling force, which is the
// right-hand side itself.
bool modalrt_kernel::solve_coupling(std::uint32_t n) noexcept { return solve_in_place(system_.data(), rhs_.data(), n); }

void modalrt_kernel::write_outputs(std::uint32_t count, modalrt_hip_output *outputs, bool impedance) noexcept
{
  const Frame        &fr = frame_;
  const std::uint32_t r  = mode_count();
  for (std::uint32_t h = 0; h < count; ++h)
    {
      const Contact     &c   = contacts_[h];
      modalrt_hip_output out{};
      out.space          = space_;
      out.proxy_triangle = MODALRT_NONE;
      out.flags = flags_[h];
      if (c.in_contact)
        {
          double u[3], u_dot[3], x_body[3], x_rel[3], spin[3], u_dot_world[3];
          if (c.proxy.active)
            proxy_displacement(contacts_[h], u, u_dot);
          else
            dot_rows3_pair(c.B, q_.data(), v_.data(), r, u, u_dot);
          for (int d = 0; d < 3; ++d)
            x_body[d] = c.rest[d] + c.anchor[d] + u[d] + c.correction[d];
          rotate(fr.rotation, x_body, x_rel);
          cross3(fr.angular_velocity, x_rel, spin);
          rotate(fr.rotation, u_dot, u_dot_world);
          rotate(fr.rotation, c.force, out.force);
          for (int d = 0; d < 3; ++d)
            {
              out.position[d] = fr.position[d] + x_rel[d];
              out.velocity[d] = fr.linear_velocity[d] + spin[d] + u_dot_world[d];
              if (impedance)
                out.force[d] = -out.force[d]; // the part pushes the HIP back
            }
          out.in_contact    = 1;
          out.active_vertex = c.vertex;
          write_proxy_output(c, out);
          if (c.candidate >= 0 && def.use_static_correction)
            out.flags |= MODALRT_HIP_CORRECTED;
          contacts_[h].validity_force = contact_validity_force(c);
          if (beyond_validity(c, c.validity_unclamped >= 0.0 ? nullptr : out.force))
            out.flags |= MODALRT_HIP_BEYOND_VALIDITY;
          contacts_[h].validity_unclamped = -1.0;
        }
      else
        {
          // Not in contact: the kernel has nothing to impose.
          double p[3], v[3];
          rotate(fr.rotation, body_inputs_[h].x, p);
          rotate(fr.rotation, body_inputs_[h].v, v);
          double spin[3];
          cross3(fr.angular_velocity, p, spin);
          for (int d = 0; d < 3; ++d)
            {
              out.position[d] = fr.position[d] + p[d];
              out.velocity[d] = fr.linear_velocity[d] + spin[d] + v[d];
            }
          out.active_vertex = MODALRT_NONE;
          if (impedance)
            ramp_released_force(h, out.force);
          out.flags = flags_[h];
        }
      outputs[h]       = out;
      last_outputs_[h] = out;
      std::copy_n(out.force, 3, &commanded_[3 * std::size_t(h)]);
    }
  // HIPs absent from this tick: nobody renders their force, but a ramp in progress runs on, so that a
  // HIP that comes back starts from where the ramp would be.
  for (std::uint32_t h = count; h < def.hip_capacity; ++h)
    {
      double zero[3];
      ramp_released_force(h, zero);
      std::copy_n(zero, 3, &commanded_[3 * std::size_t(h)]);
    }
}

void modalrt_kernel::publish_snapshot() noexcept
{
  if (++ticks_since_publish_ < def.snapshot_interval)
    return;
  ticks_since_publish_ = 0;
  SnapshotState &s     = snapshots.back();
  s.tick               = stats.tick_count;
  s.time               = stats.time;
  s.space              = space_;
  s.mode_count         = mode_count();
  std::copy_n(q_.data(), s.mode_count, s.q.data());
  std::copy_n(frame_.position, 3, s.frame_position);
  std::copy_n(frame_.orientation, 4, s.frame_orientation);
  std::copy_n(frame_.rotation, 9, s.frame_rotation);
  std::uint32_t n = 0;
  for (const Contact &c : contacts_)
    if (c.in_contact)
      {
        s.contact_vertices[n] = c.vertex;
        std::copy_n(c.correction, 3, &s.contact_corrections[3 * n]);
        ++n;
      }
  s.contact_count = n;
  snapshots.publish();
}

// f += sum_h B_h^T F_h.
void modalrt_kernel::add_contact_forces(double *f) const noexcept
{
  const std::uint32_t r = mode_count();
  for (std::uint32_t k = 0; k < active_count_; ++k)
    {
      const Contact &c = contacts_[active_[k]];
      const double  *b0 = c.B, *b1 = c.B + r, *b2 = c.B + 2 * std::size_t(r);
      const double   F0 = c.force[0], F1 = c.force[1], F2 = c.force[2];
      for (std::uint32_t i = 0; i < r; ++i)
        f[i] += b0[i] * F0 + b1[i] * F1 + b2[i] * F2;
    }
}

// =================================================================================================
// Switch of modal space (space_switch.h)
// =================================================================================================

// At a contact start (or when a sliding proxy's nearest vertex enters another region) the active
// space becomes the one whose VOI holds every active vertex, else the global space.
void modalrt_kernel::apply_switch_rule() noexcept
{
  if (!contact_started_ && !proxy_region_changed_)
    return;
  contact_started_      = false;
  proxy_region_changed_ = false;
  if (def.switch_rule != MODALRT_SWITCH_AT_CONTACT_START)
    return;
  const std::uint32_t desired = space_holding_contacts(basis, contacts_.data(), std::uint32_t(contacts_.size()));
  if (desired == MODALRT_NONE || desired == space_)
    return;
  change_space(desired);
  for (std::uint32_t &f : flags_)
    f |= MODALRT_HIP_SPACE_SWITCHED;
}

// Changes the active space, carrying the state with TRANSFER (or restarting at rest), and records
// how far the active vertices jumped.
void modalrt_kernel::change_space(std::uint32_t target) noexcept
{
  double before[3 * max_hip_capacity];
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    if (contacts_[h].in_contact)
      felt_displacement(contacts_[h], q_.data(), before + 3 * h);
  carry_modal_state(basis, space_, target, def.carry_state_on_switch != 0, q_.data(), v_.data(), q_.size(),
                    transfer_scratch_.data(), f_.data());
  ++state_stamp_;

  space_             = target;
  stats.active_space = target;
  ++stats.switch_count;
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    {
      Contact &c = contacts_[h];
      if (!c.in_contact)
        continue;
      build_row(c);
      ramping_[h] = 1; // the force follows the new space at force_rate_limit (no step)
      double after[3];
      felt_displacement(c, q_.data(), after);
      const double jump[3] = {after[0] - before[3 * h], after[1] - before[3 * h + 1], after[2] - before[3 * h + 2]};
      stats.max_switch_jump = std::max(stats.max_switch_jump, norm3(jump));
    }
  contacts_changed_ = true;
}

// =================================================================================================
// Calls of the tick thread outside the tick
// =================================================================================================

// The exact static equilibrium q = Lambda^-1 f under the given admittance forces.
int modalrt_kernel::settle(const modalrt_hip_input *inputs, std::uint32_t count) noexcept
{
  if (count > 0 && !inputs)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_settle: null inputs with count > 0");
  inputs = mapping_.to_part(inputs, count);
  if (validate(inputs, count, false) != 0)
    return failed(MODALRT_ERROR_VALUE, "modalrt_kernel_settle: an input is not finite or beyond its limit "
                                       "(workspace_radius, max_input_velocity, max_input_force) or count > hip_capacity");
  to_body(inputs, count);
  refresh_contact_set();
  for (std::uint32_t k = 0; k < active_count_; ++k)
    {
      Contact &c = contacts_[active_[k]];
      if (active_[k] < count)
        std::copy_n(body_inputs_[active_[k]].force, 3, c.force);
      else
        std::fill_n(c.force, 3, 0.0);
    }
  frame_modal_force(f_.data());
  add_contact_forces(f_.data());
  const ModalSpace &space = basis.spaces[space_];
  for (std::uint32_t i = 0; i < space.mode_count; ++i)
    {
      if (space.eigenvalues[i] > 0.0)
        q_[i] = f_[i] / space.eigenvalues[i];
      v_[i] = 0.0;
    }
  ++state_stamp_;
  update_corrections();
  return MODALRT_OK;
}

int modalrt_kernel::set_frame(const modalrt_frame_state &state) noexcept
{
  if (set_frame_state(frame_, state, def, basis.centre_of_mass()))
    return MODALRT_OK;
  ++stats.rejected_frames;
  stats.last_reject_reasons = MODALRT_REJECT_FRAME;
  return failed(MODALRT_ERROR_VALUE, "modalrt_kernel_set_frame: the frame is not finite, its quaternion is not "
                                     "near unit length, or it is beyond workspace_radius, max_input_velocity or "
                                     "max_frame_acceleration: refused, the old frame kept");
}

int modalrt_kernel::switch_space(std::uint32_t space) noexcept
{
  if (space >= basis.space_count())
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_switch_space: space out of range");
  if (space != space_)
    change_space(space);
  refresh_contact_set();
  return MODALRT_OK;
}

void modalrt_kernel::reset() noexcept
{
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    {
      if (contacts_[h].in_contact)
        end_contact(h);
      contacts_[h].armed = true;
      last_outputs_[h]   = modalrt_hip_output{};
      last_outputs_[h].active_vertex = last_outputs_[h].proxy_triangle = MODALRT_NONE;
    }
  std::fill(q_.begin(), q_.end(), 0.0);
  std::fill(v_.begin(), v_.end(), 0.0);
  ++state_stamp_;
  space_              = def.initial_space;
  stats.active_space  = space_;
  stats.time          = 0.0;
  stats.fail_safe_run = 0;
  contact_started_   = false;
  observed_count_    = 0;
  fail_safe_plane_.forget();
  refresh_contact_set();
}
