// The live view of the run loop (realtime/tools/run_loop.h): the session `modal-rt run` plays or
// `serve` bridges, watched live in the browser (--view P, watch-only: the HIPs belong to the script
// or the UDP device), and `modal-rt view`, where the page presses the part with the mouse device
// (mouse_device.h). Same page, same protocol.
//
// Threads: the haptic thread only publishes, wait-free, what each tick produced (the HIP outputs,
// its timing, the kernel's counters) into a triple buffer: no lock, no allocation. The run loop's
// display thread, after each snapshot it reads, hands it to the view (RunObserver): the view builds
// the frame there from that snapshot and the newest tick's outputs, so the kernel keeps its one
// snapshot reader, and tells the server thread, which sends it to every browser.
#pragma once

#include "mouse_device.h"
#include "run_command.h" // realtime/tools
#include "view_server.h"

#include <memory>
#include <string>

namespace modalrt_view
{
  constexpr std::uint32_t run_view_max_hips = 16;

  // --view P of run and serve (a modalrt_tool::WatchStarter): starts the server on loopback port
  // `port` (0: any free port), watch-only.
  std::unique_ptr<modalrt_tool::RunObserver> start_watch_view(const modalrt_tool::ViewContext &context, unsigned port,
                                                              std::string &error);

  // `modal-rt view`: the server of `options`; the page's presses go to `mouse`.
  std::unique_ptr<modalrt_tool::RunObserver> start_mouse_view(const modalrt_tool::ViewContext &context,
                                                              MouseDevice &mouse, const ServerOptions &options,
                                                              std::string &error);
} // namespace modalrt_view
