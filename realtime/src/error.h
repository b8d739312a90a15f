// Errors of the non-real-time calls (load, create, self-check). They are thrown inside the library
// and turned into a status code and a thread-local message at the C API; ticks never throw.
#pragma once

#include <exception>
#include <new>
#include <sstream>
#include <string>
#include <utility>

namespace modalrt
{
  struct Error
  {
    int         status;
    std::string message;
  };

  [[noreturn]] inline void fail(int status, std::string message) { throw Error{status, std::move(message)}; }

  // Concatenates anything streamable: fail(MODALRT_ERROR_VALUE, cat("value ", x, " at ", i)).
  template <typename... Parts>
  std::string cat(const Parts &...parts)
  {
    std::ostringstream out;
    out.precision(17);
    (out << ... << parts);
    return out.str();
  }

  void set_last_error(const std::string &message);
  // Without allocation, for the calls of the tick thread: sets the message, returns `status`.
  int failed(int status, const char *message) noexcept;

  // Runs `body` (returning a status), mapping thrown errors to their status and message.
  template <typename Body>
  int guarded(Body &&body) noexcept
  {
    try
      {
        return body();
      }
    catch (const Error &e)
      {
        set_last_error(e.message);
        return e.status;
      }
    catch (const std::bad_alloc &)
      {
        set_last_error("out of memory");
        return -6; // MODALRT_ERROR_OUT_OF_MEMORY
      }
    catch (const std::exception &e)
      {
        set_last_error(e.what());
        return -1;
      }
    catch (...)
      {
        set_last_error("unknown error");
        return -1;
      }
  }
} // namespace modalrt
