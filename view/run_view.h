// `modal-rt run|serve --view P`: the session being played or served, watched live in the browser
// through the same page as `modal-rt view`, watch-only (the HIPs belong to the script or the UDP
// device; the page does not press).
//
// Threads: the haptic thread only publishes, wait-free, what the tick produced (the device is
// wrapped: after each tick's writes it copies the HIP outputs and the kernel's counters into a
// triple buffer; no lock, no allocation). The display thread of the run loop, after each snapshot it
// reads, hands it to the view (DisplayObserver): the view builds the frame there from that snapshot
// and the newest haptic outputs, so the kernel keeps its one snapshot reader. The server thread
// sends the newest frame to every browser.
#pragma once

#include "devices.h"  // realtime/tools
#include "run_loop.h" // realtime/tools

#include <modalrt/modalrt.h>

#include <memory>
#include <string>

namespace modalrt_view
{
  constexpr std::uint32_t run_view_max_hips = 16;

  // Starts the server on loopback port `port` (0: any free port) and wraps `device` so the view sees
  // each tick's outputs. `driver` is "run" or "serve". Returns the display thread's observer (it
  // stops the server when destroyed; destroy it before the kernel and the device), or nullptr and a
  // message in `error`.
  std::unique_ptr<modalrt_tool::DisplayObserver>
  start_run_view(const modalrt_basis *basis, const std::string &basis_path, modalrt_kernel *kernel,
                 std::unique_ptr<modalrt_tool::Device> &device, unsigned port, const std::string &driver,
                 std::string &error);
} // namespace modalrt_view
