// The switch of modal space: the rule applied at a contact start, the change of space that carries
// the modal state with TRANSFER, and the explicit switch of the C API.
#include "kernel.h"

#include "dense.h"
#include "error.h"
#include "vector3.h"

#include <algorithm>

using namespace modalrt;

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
  std::uint32_t desired = MODALRT_NONE;
  for (const Contact &c : contacts_)
    {
      if (!c.in_contact)
        continue;
      const std::uint32_t region = basis.region[c.vertex];
      desired                    = desired == MODALRT_NONE || desired == region ? region : 0u;
    }
  if (desired == MODALRT_NONE || desired == space_)
    return;
  change_space(desired);
  for (std::uint32_t &f : flags_)
    f |= MODALRT_HIP_SPACE_SWITCHED;
}

// =================================================================================================
// Switch of modal space
// =================================================================================================

// Changes the active space, carrying the state with TRANSFER (or restarting at rest), and records
// how far the active vertices jumped.
void modalrt_kernel::change_space(std::uint32_t target) noexcept
{
  const std::uint32_t source = space_;
  const std::uint32_t r_from = basis.spaces[source].mode_count, r_to = basis.spaces[target].mode_count;
  double              before[3 * max_hip_capacity];
  for (std::uint32_t h = 0; h < def.hip_capacity; ++h)
    if (contacts_[h].in_contact)
      felt_displacement(contacts_[h], q_.data(), before + 3 * h);

  const modalrt::Vector<double> &T = basis.transfer(target, source);
  if (def.carry_state_on_switch && !T.empty())
    {
      double *q_to = transfer_scratch_.data(), *v_to = f_.data();
      for (std::uint32_t a = 0; a < r_to; ++a)
        dot_pair(&T[std::size_t(a) * r_from], q_.data(), v_.data(), r_from, q_to[a], v_to[a]);
      std::copy_n(q_to, r_to, q_.data());
      std::copy_n(v_to, r_to, v_.data());
    }
  else
    {
      std::fill_n(q_.data(), r_to, 0.0);
      std::fill_n(v_.data(), r_to, 0.0);
    }
  std::fill(q_.begin() + r_to, q_.end(), 0.0);
  std::fill(v_.begin() + r_to, v_.end(), 0.0);
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
int modalrt_kernel::switch_space(std::uint32_t space) noexcept
{
  if (space >= basis.space_count())
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_switch_space: space out of range");
  if (space != space_)
    change_space(space);
  refresh_contact_set();
  return MODALRT_OK;
}
