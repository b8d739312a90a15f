// modal-rt's commands and its main, as a library (modal_rt_tools): the app that links it says which
// commands it adds. The tools know no app: the browser view (view/) links them and adds `modal-rt
// view` and the --view P of run and serve through ToolExtensions, never the other way round.
#pragma once

#include "run_command.h"

#include <functional>
#include <string>
#include <vector>

namespace modalrt_tool
{
  // A command an app adds: `modal-rt NAME ARGUMENTS...`.
  struct Command
  {
    std::string name;
    std::string summary; // what it does, in a sentence: its line of `modal-rt --help`
    // The arguments after the name (argv[0] the first); the exit status. Handles its own --help
    // (mrt/command_line.h: its option table).
    std::function<int(int argc, char **argv)> run;
  };

  struct ToolExtensions
  {
    std::vector<Command> commands;
    WatchStarter         watch = nullptr; // --view P on run and serve (null: refused, built without the view)
  };

  // modal-rt: info, verify, run, serve, and the extensions' commands. Exit status: 0 success (or
  // --help), 1 bad basis or failed check, 2 bad command line.
  int tool_main(int argc, char **argv, const ToolExtensions &extensions);
} // namespace modalrt_tool
