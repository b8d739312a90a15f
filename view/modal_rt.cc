// modal-rt with the browser view: the tools' commands (realtime/tools) plus `modal-rt view` and the
// --view P of run and serve. Built instead of realtime/app/modal_rt.cc when Boost.Beast is found.
#include "view_command.h"

int main(int argc, char **argv) { return modalrt_tool::tool_main(argc, argv, modalrt_view::view_extensions()); }
