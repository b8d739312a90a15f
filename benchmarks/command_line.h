// Command-line helpers shared by the benchmark programs.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace modal_haptics_bench
{
  [[noreturn]] inline void usage(const char *text)
  {
    std::fprintf(stderr, "usage: %s\n", text);
    std::exit(2);
  }

  // "a,b,c" -> {"a", "b", "c"}
  inline std::vector<std::string> split(const std::string &list)
  {
    std::vector<std::string> items;
    std::istringstream       in(list);
    for (std::string item; std::getline(in, item, ',');)
      items.push_back(item);
    return items;
  }

  // "10,200" -> {10, 200}; throws std::invalid_argument on a non-number (std::stoul).
  inline std::vector<std::uint32_t> numbers(const std::string &list)
  {
    std::vector<std::uint32_t> values;
    for (const std::string &item : split(list))
      values.push_back(std::uint32_t(std::stoul(item)));
    return values;
  }
} // namespace modal_haptics_bench
