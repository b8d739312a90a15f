// `modal-rt view --basis F.mrt [--port P]`: the live view of a basis, pressed with a mouse; and what
// the view adds to modal-rt's tools (realtime/tools/tool_main.h).
#pragma once

#include "tool_main.h" // realtime/tools

namespace modalrt_view
{
  // Exit status: 0 success (or --help), 1 bad basis or server failure, 2 bad command line.
  int view_command(int argc, char **argv);

  // The command `view` and the --view P of run and serve.
  modalrt_tool::ToolExtensions view_extensions();
} // namespace modalrt_view
