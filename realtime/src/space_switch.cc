// The switch of modal space (space_switch.h).
#include "space_switch.h"

#include "dense.h"

#include <algorithm>

using namespace modalrt;

std::uint32_t modalrt::space_holding_contacts(const modalrt_basis &basis, const Contact *contacts,
                                              std::uint32_t count) noexcept
{
  std::uint32_t desired = MODALRT_NONE;
  for (std::uint32_t h = 0; h < count; ++h)
    {
      const Contact &c = contacts[h];
      if (!c.in_contact)
        continue;
      const std::uint32_t region = basis.region[c.vertex];
      desired                    = desired == MODALRT_NONE || desired == region ? region : 0u;
    }
  return desired;
}

void modalrt::carry_modal_state(const modalrt_basis &basis, std::uint32_t source, std::uint32_t target, bool carry,
                                double *q, double *v, std::size_t max_modes, double *scratch_q,
                                double *scratch_v) noexcept
{
  const std::uint32_t r_from = basis.spaces[source].mode_count, r_to = basis.spaces[target].mode_count;
  const modalrt::Vector<double> &T = basis.transfer(target, source);
  if (carry && !T.empty())
    {
      for (std::uint32_t a = 0; a < r_to; ++a)
        dot_pair(&T[std::size_t(a) * r_from], q, v, r_from, scratch_q[a], scratch_v[a]);
      std::copy_n(scratch_q, r_to, q);
      std::copy_n(scratch_v, r_to, v);
    }
  else
    {
      std::fill_n(q, r_to, 0.0);
      std::fill_n(v, r_to, 0.0);
    }
  std::fill(q + r_to, q + max_modes, 0.0);
  std::fill(v + r_to, v + max_modes, 0.0);
}
