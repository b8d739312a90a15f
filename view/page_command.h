// The commands the page sends over the WebSocket (view/README.md, "Commands"), parsed from the bytes
// of one message with no basis and no device: the mouse device (mouse_device.h) applies what this
// returns, and tests/fuzz/fuzz_page_commands.cc drives this parser alone.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace modalrt_view
{
  struct PageCommand
  {
    enum Verb
    {
      press,   // "press HIP VERTEX FORCE": press VERTEX along its inward normal
      slide,   // "slide HIP VERTEX X Y Z FORCE": slide under the surface point (X, Y, Z) [m]
      release, // "release HIP"
    };
    Verb          verb     = release;
    std::uint32_t hip      = 0;
    std::uint32_t vertex   = 0;
    double        point[3] = {0.0, 0.0, 0.0}; // [m] slide only
    // [N] along the inward normal. Not range-checked: a non-finite or absurd force (or point)
    // reaches the kernel, which rejects it as it would any device's; a FORCE that is no number is 0.
    double force = 0.0;
  };

  // One message of `size` bytes (any bytes). HIP < `hips`, VERTEX < `vertices`; slide only when
  // `sliding`. Returns "" with `command` filled, or the reply for the page ("error: ..."), which
  // quotes the message as printable ASCII of at most 80 characters (a text frame must be UTF-8).
  std::string parse_page_command(const char *bytes, std::size_t size, std::uint32_t hips, std::uint32_t vertices,
                                 bool sliding, PageCommand &command);

  // A message as the replies quote it: '...', printable ASCII, at most 80 characters.
  std::string quoted_page_message(const char *bytes, std::size_t size);
} // namespace modalrt_view
