// The meshing tests' one check: prints "ok" or "FAIL" with what was checked and counts failures.
#pragma once

#include <iostream>
#include <string>

namespace meshing_test
{
  inline int failures = 0;

  inline void check(const bool condition, const std::string &what)
  {
    std::cout << (condition ? "  ok    " : "  FAIL  ") << what << std::endl;
    if (!condition)
      ++failures;
  }
} // namespace meshing_test
