// modal-study's companions: the programs and scripts it runs as child processes (scripts/study_report.py,
// bench-basis-cost), how it finds them and how it runs them. No deal.II here but its exceptions.
#include "study/modal_study.h"

#include <deal.II/base/exceptions.h>

#include <cerrno>
#include <cstring>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

namespace modal_haptics
{
  namespace fs = std::filesystem;
  using dealii::ExcMessage;

  // The first of: each folder of `from_bin` relative to this program's own folder (where an installed
  // program finds what was installed with it, even in a moved prefix), then `build_folder` (the
  // absolute folder the build passed at compile time: the build or the source tree).
  fs::path find_companion(const std::string &name, const std::vector<std::string> &from_bin,
                          const std::string &build_folder, const std::string &hint)
  {
    std::error_code       code;
    const fs::path        exe = fs::read_symlink("/proc/self/exe", code);
    std::vector<fs::path> folders;
    for (const auto &relative : from_bin)
      if (!code)
        folders.push_back(exe.parent_path() / relative);
    folders.emplace_back(build_folder);
    std::string tried;
    for (const fs::path &folder : folders)
      {
        const fs::path file = (folder / name).lexically_normal();
        if (fs::is_regular_file(file, code))
          return file;
        tried += (tried.empty() ? "" : " nor ") + file.string();
      }
    AssertThrow(false, ExcMessage("Cannot find " + name + ": neither " + tried + " exists" + hint + "."));
    return {};
  }

  namespace
  {
    // What the child wrote on the pipe's read end, until it closed it.
    std::string read_all(const int fd)
    {
      std::string text;
      char        buffer[4096];
      for (ssize_t n; (n = read(fd, buffer, sizeof buffer)) != 0;)
        if (n > 0)
          text.append(buffer, std::size_t(n));
        else if (errno != EINTR)
          break;
      return text;
    }
  } // namespace

  // arguments[0] (an absolute path) with the rest as its arguments; its standard output goes to
  // `output` if given, else to ours; its standard error is ours. Returns its exit status.
  int run_child(std::vector<std::string> arguments, std::string *output, const std::string &hint)
  {
    std::vector<char *> argv;
    for (auto &argument : arguments)
      argv.push_back(argument.data());
    argv.push_back(nullptr);
    int                        pipe_ends[2] = {-1, -1};
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (output != nullptr)
      {
        AssertThrow(pipe(pipe_ends) == 0, ExcMessage(std::string("Cannot create a pipe: ") + std::strerror(errno)));
        posix_spawn_file_actions_adddup2(&actions, pipe_ends[1], STDOUT_FILENO);
        posix_spawn_file_actions_addclose(&actions, pipe_ends[0]);
        posix_spawn_file_actions_addclose(&actions, pipe_ends[1]);
      }
    pid_t     pid     = 0;
    const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (output != nullptr)
      {
        close(pipe_ends[1]);
        *output = spawned == 0 ? read_all(pipe_ends[0]) : std::string();
        close(pipe_ends[0]);
      }
    AssertThrow(spawned == 0, ExcMessage("Cannot start " + arguments[0] + ": " + std::strerror(spawned) + hint + "."));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
      ;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
  }
} // namespace modal_haptics
