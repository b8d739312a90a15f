// The self-check behind `modal-rt verify` (throws modalrt::Error).
#pragma once

#include "basis.h"

namespace modalrt
{
  void verify_case(const modalrt_basis &basis, std::uint32_t index, modalrt_verify_case &result);
  int  verify(const modalrt_basis &basis, modalrt_verify_report &report);
} // namespace modalrt
