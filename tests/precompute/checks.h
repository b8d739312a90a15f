// The checks of a test program without a framework: each prints "ok" or "FAILED" with what it
// asserts, and the failures decide the exit code.
#pragma once

#include <cstdio>
#include <string>

namespace modal_haptics::testing
{
  inline int failures = 0;

  inline void check(const bool ok, const std::string &what)
  {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
    failures += !ok;
  }

  // Prints the count of failed checks; 0 when none failed, 1 otherwise.
  inline int exit_code()
  {
    std::printf("%d failed\n", failures);
    return failures == 0 ? 0 : 1;
  }
} // namespace modal_haptics::testing
