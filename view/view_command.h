// `modal-rt view --basis F.mrt [--port P]`: the live view of a basis, pressed with a mouse.
#pragma once

namespace modalrt_view
{
  // Exit status: 0 success, 1 bad basis or server failure, 2 bad command line.
  int         view_command(int argc, char **argv);
  const char *view_usage();
} // namespace modalrt_view
