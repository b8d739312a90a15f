// Command-line helpers shared by the benchmark programs.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
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

  // "FILE [--name VALUE ...]": the one positional argument into 'file' (a later one replaces it),
  // each --name's value to option(name, value), which returns false for a name it does not know.
  // usage(usage_text) for an unknown name, a name without a value, a value that is not a number
  // (option's std::stoul/std::stoi throw std::logic_error) or no file.
  template <typename Option>
  void parse_file_and_options(const int argc, char **argv, std::string &file, const Option &option,
                              const char *usage_text)
  {
    try
      {
        for (int k = 1; k < argc; ++k)
          {
            const std::string arg = argv[k];
            if (arg.rfind("--", 0) != 0)
              file = arg;
            else if (k + 1 >= argc || !option(arg, std::string(argv[++k])))
              usage(usage_text);
          }
      }
    catch (const std::logic_error &)
      {
        usage(usage_text);
      }
    if (file.empty())
      usage(usage_text);
  }
} // namespace modal_haptics_bench
