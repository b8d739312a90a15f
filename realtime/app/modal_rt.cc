// modal-rt without the browser view: the tools' commands alone (info, verify, run, serve). With
// Boost.Beast at configure time the view's folder builds modal-rt instead (view/modal_rt.cc), adding
// `modal-rt view` and --view P.
#include "tool_main.h"

int main(int argc, char **argv) { return modalrt_tool::tool_main(argc, argv, {}); }
