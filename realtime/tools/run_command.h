// `modal-rt run`: a scripted session through the kernel in real time; `modal-rt serve`: the same
// loop with a device on the other end of a UDP socket (see realtime/README.md).
#pragma once

#include <string>

namespace modalrt_tool
{
  // `modal-rt run` (serve false) or `modal-rt serve` (serve true: the UDP bridge, udp_device.h).
  // argv[0] is the first argument after the command. Exit status: 0 done (end of session or
  // Ctrl-C, or --help), 1 bad basis/session file, device or output, 2 bad command line.
  int         run_command(int argc, char **argv, bool serve);
  std::string run_usage();   // the usage lines, from the option table
  std::string serve_usage();
} // namespace modalrt_tool
