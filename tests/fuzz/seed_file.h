// Writing one seed of a fuzzer's corpus (make_seed_corpus, make_udp_seed_corpus).
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace seed
{
  // Writes `bytes` to DIR/NAME and prints its size; false (with a message) if it cannot.
  inline bool save(const std::string &dir, const char *name, const std::vector<unsigned char> &bytes)
  {
    const std::string path = dir + "/" + name;
    std::FILE        *file = std::fopen(path.c_str(), "wb");
    const bool        ok   = file && std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
    if (file && std::fclose(file) != 0)
      return false;
    if (ok)
      std::printf("%-40s %6zu bytes\n", name, bytes.size());
    else
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
    return ok;
  }
} // namespace seed
