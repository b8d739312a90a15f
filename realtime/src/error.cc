#include "error.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <cstring>

namespace modalrt
{
  namespace
  {
    // Fixed-size, so that reading the message never allocates and never dangles.
    thread_local char last_error[1024] = "";
  } // namespace

  void set_last_error(const std::string &message)
  {
    const std::size_t n = std::min(message.size(), sizeof(last_error) - 1);
    std::memcpy(last_error, message.data(), n);
    last_error[n] = '\0';
  }

  int failed(int status, const char *message) noexcept
  {
    const std::size_t n = std::min(std::strlen(message), sizeof(last_error) - 1);
    std::memcpy(last_error, message, n);
    last_error[n] = '\0';
    return status;
  }
} // namespace modalrt

extern "C" const char *modalrt_last_error_message(void) { return modalrt::last_error; }
