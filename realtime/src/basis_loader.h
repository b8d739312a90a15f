// Loading a .mrt basis file; throws modalrt::Error with a message naming the file and the section.
#pragma once

#include "basis.h"

#include <memory>
#include <string>

namespace modalrt
{
  std::unique_ptr<modalrt_basis> load_basis_file(const std::string &path);
  std::unique_ptr<modalrt_basis> load_basis_memory(const void *bytes, std::size_t size);
} // namespace modalrt
