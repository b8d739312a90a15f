// The display side of the kernel: reading snapshots and reconstructing the display surface.
#pragma once

#include "snapshot.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  // Copies the newest published state into `snapshot`; 1 if newer than the previous read, else 0.
  int read_snapshot(modalrt_kernel &kernel, modalrt_snapshot &snapshot) noexcept;

  // u = Phi q (+ corrections, positions, world pose per `flags`) for vertices [begin, end).
  template <typename Out>
  int reconstruct(const modalrt_snapshot &snapshot, std::uint32_t begin, std::uint32_t end, std::uint32_t flags,
                  Out *out) noexcept;
} // namespace modalrt
