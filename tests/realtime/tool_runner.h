// For the tests that run the modal-rt program (MODAL_RT_PROGRAM, its path, defined by CMake) and
// read the files it writes: the program's exit status and output, and its CSV outputs.
#pragma once

#include "test_support.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace test
{
  // Runs `modal-rt ARGUMENTS`; returns its exit status and its output (stdout and stderr).
  inline int modal_rt(const std::string &arguments, std::string &output)
  {
    // One file per test process: ctest runs the tests that call modal-rt side by side in one folder.
    const std::string capture = "modal_rt_output." + std::to_string(getpid()) + ".txt";
    const std::string command = std::string(MODAL_RT_PROGRAM) + " " + arguments + " > " + capture + " 2>&1";
    const int         status  = std::system(command.c_str());
    output                    = read_text(capture);
    std::remove(capture.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  inline bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

  // The rows of a CSV output (comment lines skipped), each split at commas; rows[0] is the header.
  inline std::vector<std::vector<std::string>> read_csv(const std::string &path)
  {
    std::ifstream                         file(path);
    std::vector<std::vector<std::string>> rows;
    for (std::string line; std::getline(file, line);)
      {
        if (line.empty() || line[0] == '#')
          continue;
        std::vector<std::string> fields(1);
        for (char c : line)
          if (c == ',')
            fields.emplace_back();
          else
            fields.back() += c;
        rows.push_back(fields);
      }
    return rows;
  }

  // The index of column `name` in a CSV header (a failed check and 0 if it has none).
  inline std::size_t column(const std::vector<std::string> &header, const std::string &name)
  {
    const auto at = std::find(header.begin(), header.end(), name);
    ENSURE(at != header.end());
    return at == header.end() ? 0 : std::size_t(at - header.begin());
  }
} // namespace test
