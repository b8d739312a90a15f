// Contacts of the haptic loop: the release rules, contact detection (over the snap search,
// snap_search.h), the row B of each active vertex and the residual compliances between contacts.
// The switch of modal space is in kernel.cc (over space_switch.h).
#include "kernel.h"

#include "coupling.h"
#include "dense.h"
#include "error.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>

using namespace modalrt;

// =================================================================================================
// Release, snap and switch rules (tick phases)
// =================================================================================================
// Impedance: released when pulled out beyond release_distance along the outward normal, or dragged
// beyond release_drag_distance across it. Admittance: released when the user's force pulls outward
// by more than release_force.
// HIPs beyond `count` are absent this tick and released.
void modalrt_kernel::apply_release_rules(std::uint32_t count, bool impedance) noexcept
{
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    {
      Contact &c = contacts_[h];
      if (!c.in_contact)
        continue;
      if (h >= count)
        {
          end_contact(h);
          continue;
        }
      if (!def.auto_release)
        continue;
      const BodyInput &in = body_inputs_[h];
      bool             release_now;
      if (impedance)
        {
          double u[3], gap[3];
          felt_displacement(c, q_.data(), u);
          for (int d = 0; d < 3; ++d)
            gap[d] = in.x[d] - (c.rest[d] + u[d] + c.correction[d]);
          const double normal_part = dot3(gap, c.normal);
          double       across[3];
          for (int d = 0; d < 3; ++d)
            across[d] = gap[d] - c.anchor[d] - normal_part * c.normal[d];
          release_now = normal_part > def.release_distance || norm3(across) > def.release_drag_distance;
        }
      else
        release_now = dot3(in.force, c.normal) > def.release_force;
      if (release_now)
        {
          end_contact(h);
          flags_[h] |= MODALRT_HIP_RELEASED;
        }
    }
}

bool modalrt_kernel::detect_contacts(std::uint32_t count) noexcept
{
  bool started = false;
  for (std::uint32_t h = 0; h < count; ++h)
    {
      Contact &c = contacts_[h];
      if (c.in_contact)
        continue;
      std::uint32_t vertex;
      double        gap[3], signed_distance;
      const bool    found = snap_search_.find(basis, space_, q_.data(), def.snap_distance, body_inputs_[h].x, vertex,
                                                gap, signed_distance);
      if (!c.armed)
        {
          // After a release the HIP must leave the surface before it may snap again, unless it presses
          // in again from inside: it does not fall through the part (the new contact's force starts at
          // force_rate_limit, begin_contact).
          const bool pressing_in =
            found && signed_distance <= 0.0 && dot3(body_inputs_[h].v, &basis.normals[3 * std::size_t(vertex)]) < 0.0;
          if (found && signed_distance <= def.release_distance && !pressing_in)
            continue;
          c.armed = true;
        }
      if (found && signed_distance <= def.contact_tolerance)
        {
          begin_contact(h, vertex, gap);
          flags_[h] |= MODALRT_HIP_CONTACT_STARTED;
          started = true;
        }
    }
  return started;
}

// =================================================================================================
// Contacts and their rows
// =================================================================================================

// `offset`: the HIP's position relative to the deformed vertex (body frame), or null; its
// tangential part becomes the contact's anchor.
void modalrt_kernel::begin_contact(std::uint32_t hip, std::uint32_t vertex, const double *offset) noexcept
{
  Contact &c   = contacts_[hip];
  c.in_contact = true;
  c.armed      = false;
  c.vertex     = vertex;
  std::copy_n(&basis.vertices[3 * std::size_t(vertex)], 3, c.rest);
  std::copy_n(&basis.normals[3 * std::size_t(vertex)], 3, c.normal);
  std::fill_n(c.force, 3, 0.0);
  std::fill_n(c.correction, 3, 0.0);
  std::fill_n(c.anchor, 3, 0.0);
  c.validity_force = 0.0;
  c.validity_limit = c.validity_unclamped = -1.0;
  if (offset)
    {
      const double normal_part = dot3(offset, c.normal);
      for (int d = 0; d < 3; ++d)
        c.anchor[d] = offset[d] - normal_part * c.normal[d];
    }
  build_row(c);
  if (def.contact_mode == MODALRT_CONTACT_PROXY)
    begin_proxy(hip, offset != nullptr);
  set_contact_stiffness(mapping_, def.coupling_stiffness, c);
  contacts_changed_ = true;
  contact_started_  = true;
  ramping_[hip]     = 1; // the force starts at force_rate_limit from the one last commanded (no step)
}

void modalrt_kernel::end_contact(std::uint32_t hip) noexcept
{
  Contact &c   = contacts_[hip];
  c.in_contact = false;
  c.armed      = false;
  c.vertex     = MODALRT_NONE;
  c.candidate  = -1;
  std::fill_n(c.force, 3, 0.0);
  std::fill_n(c.correction, 3, 0.0);
  std::fill_n(c.anchor, 3, 0.0);
  c.proxy.clear();
  c.validity_force = 0.0;
  c.validity_limit = c.validity_unclamped = -1.0;
  contacts_changed_ = true;
  ramping_[hip]     = 1; // the device's force ramps to zero (no step of the kernel's own)
}

// B of the active vertex in the active space (a proxy: the blend of its triangle's rows).
void modalrt_kernel::build_row(Contact &c) noexcept
{
  if (c.proxy.active)
    compose_proxy(c, true);
  else
    c.candidate = load_vertex_row(c.vertex, c.B);
}

// The contact row of a vertex in the active space: the stored candidate block (with its static
// correction), else the patch average of the display modes sum_j w_j Phi_j. Returns the candidate
// index, -1 if none.
int modalrt_kernel::load_vertex_row(std::uint32_t vertex, double *B) const noexcept
{
  const ModalSpace   &space     = basis.spaces[space_];
  const std::uint32_t r         = space.mode_count;
  const int           candidate = space.candidate_index(vertex);
  if (candidate >= 0)
    std::copy_n(&space.candidate_modes[3 * std::size_t(r) * std::size_t(candidate)], 3 * std::size_t(r), B);
  else
    patch_row(basis, space, vertex, 0, r, B);
  return candidate;
}

void modalrt_kernel::felt_displacement(const Contact &c, const double *q, double u[3]) const noexcept
{
  dot_rows3(c.B, q, mode_count(), u);
}

// The list of contacts and their residual compliances, after contacts began or ended.
void modalrt_kernel::refresh_contact_set() noexcept
{
  if (!contacts_changed_)
    return;
  contacts_changed_ = false;
  coupling_dirty_   = true;
  active_count_     = 0;
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    if (contacts_[h].in_contact)
      active_[active_count_++] = h;
  const std::uint32_t n3 = 3 * active_count_;
  for (std::uint32_t a = 0; a < active_count_; ++a)
    for (std::uint32_t b = 0; b < active_count_; ++b)
      {
        double C[9];
        pair_compliance(contacts_[active_[a]], contacts_[active_[b]], C);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            compliance_[(3 * a + i) * n3 + 3 * b + j] = C[3 * i + j];
      }
}

// C_ab: the active space's residual coupling of the two candidates (ModalSpace::residual_coupling:
// the own block, a stored cross block, or the far field's Z_a Z_b^T), 0 when there is none, when
// either vertex has no correction, or when corrections are off.
void modalrt_kernel::pair_compliance(const Contact &a, const Contact &b, double C[9]) const noexcept
{
  if (a.proxy.active || b.proxy.active)
    return proxy_pair_compliance(a, b, C);
  std::fill_n(C, 9, 0.0);
  if (!def.use_static_correction || a.candidate < 0 || b.candidate < 0)
    return;
  basis.spaces[space_].residual_coupling(std::uint32_t(a.candidate), std::uint32_t(b.candidate), C);
}

// B_a G B_b^T and B_a H B_b^T (+ C_ab) for every pair of active contacts (dense.h's add_own_gram,
// add_pair_gram, which the sliding contact's pair blocks use too). A contact's own block (a = b) is
// symmetric: its six distinct entries are summed; a sliding contact, which refreshes it whenever its
// proxy moves, takes it from its triangle's pair blocks instead (proxy_coupling_block: no pass over
// the modes).
void modalrt_kernel::refresh_coupling_matrices() noexcept
{
  coupling_dirty_                   = false;
  const ModalIntegrator &integrator = integrators_[space_];
  const std::uint32_t    r = integrator.mode_count(), n = active_count_, n3 = 3 * n;
  const double          *g1 = integrator.g1(), *g2 = integrator.g2();
  for (std::uint32_t a = 0; a < n; ++a)
    {
      double s[9], sv[9];
      if (contacts_[active_[a]].proxy.active)
        proxy_coupling_block(contacts_[active_[a]].proxy, s, sv); // from its triangle's pair blocks
      else
        {
          std::fill_n(s, 9, 0.0), std::fill_n(sv, 9, 0.0);
          add_own_gram(contacts_[active_[a]].B, g1, g2, r, 0, r, s, sv);
        }
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d)
          {
            const std::size_t ab   = (3 * a + c) * n3 + 3 * a + d;
            coupling_[ab]          = s[3 * c + d] + compliance_[ab];
            coupling_velocity_[ab] = sv[3 * c + d];
          }
    }
  for (std::uint32_t a = 0; a < n; ++a)
    for (std::uint32_t b = a + 1; b < n; ++b)
      {
        double s[9] = {}, sv[9] = {};
        add_pair_gram(contacts_[active_[a]].B, contacts_[active_[b]].B, g1, g2, r, 0, r, s, sv);
        for (int c = 0; c < 3; ++c)
          for (int d = 0; d < 3; ++d)
            {
              const std::size_t ab = (3 * a + c) * n3 + 3 * b + d, ba = (3 * b + d) * n3 + 3 * a + c;
              coupling_[ab]          = s[3 * c + d] + compliance_[ab];
              coupling_[ba]          = s[3 * c + d] + compliance_[ba];
              coupling_velocity_[ab] = coupling_velocity_[ba] = sv[3 * c + d];
            }
      }
}

// =================================================================================================
// Calls of the tick thread outside the tick
// =================================================================================================
int modalrt_kernel::contact_begin(std::uint32_t hip, std::uint32_t vertex) noexcept
{
  if (hip >= def.hip_capacity || vertex >= basis.vertex_count)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_contact_begin: hip or vertex out of range");
  if (contacts_[hip].in_contact)
    end_contact(hip);
  begin_contact(hip, vertex, nullptr);
  apply_switch_rule();
  refresh_contact_set();
  return MODALRT_OK;
}

int modalrt_kernel::release(std::uint32_t hip) noexcept
{
  if (hip >= def.hip_capacity)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_release_hip: hip out of range");
  if (contacts_[hip].in_contact)
    end_contact(hip);
  refresh_contact_set();
  return MODALRT_OK;
}

// Every HIP released and disarmed: a HIP of the new session must approach from outside the surface.
void modalrt_kernel::begin_session() noexcept
{
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    {
      if (contacts_[h].in_contact)
        end_contact(h);
      contacts_[h].armed = false;
    }
  refresh_contact_set();
}
