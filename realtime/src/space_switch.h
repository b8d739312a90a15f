// The switch of modal space: the space the switch rule wants for the contacts, and the modal state
// carried into a new space with TRANSFER. The kernel applies them (kernel.cc: the rule at a
// contact start, the rows and the ramp of each contact after a switch).
#pragma once

#include "basis.h"
#include "contact_state.h"

#include <cstddef>
#include <cstdint>

namespace modalrt
{
  // The space whose VOI holds the vertex of every contact in contact among `contacts` (`count` of
  // them), else the global space 0; MODALRT_NONE when none is in contact.
  std::uint32_t space_holding_contacts(const modalrt_basis &basis, const Contact *contacts, std::uint32_t count) noexcept;

  // The modal state q, v (`max_modes` each) of space `source` carried into space `target` with
  // TRANSFER when `carry` and the basis has it, else restarted at rest; the modes beyond target's
  // are zero. `scratch_q`, `scratch_v`: target's mode count each, neither q nor v.
  void carry_modal_state(const modalrt_basis &basis, std::uint32_t source, std::uint32_t target, bool carry, double *q,
                         double *v, std::size_t max_modes, double *scratch_q, double *scratch_v) noexcept;
} // namespace modalrt
