// libFuzzer harness of the parser of the page's commands (view/page_command.cc), built by
// tests/fuzz/CMakeLists.txt with clang -fsanitize=fuzzer,address,undefined and run by
// scripts/test-kernel-checks. Every WebSocket message a browser sends to `modal-rt view` reaches
// parse_page_command, so it must never read outside the message, and what it returns must keep its
// promises: an accepted command names a HIP and a vertex in range and slides only with sliding
// contacts; a refusal is a short "error: ..." of printable ASCII (it goes back as a text frame, which
// must be UTF-8); an accepted command written out again as text parses to the same command.
//
// Each input is one message, parsed for the mouse's 2 HIPs over 1000 vertices, with and without
// sliding contacts.
#include "page_command.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace
{
  using modalrt_view::PageCommand;

  constexpr std::uint32_t hips = 2, vertices = 1000;

  // A broken promise of the parser is a finding: report it and abort, so libFuzzer keeps the input.
  void expect(bool condition, const char *what)
  {
    if (!condition)
      {
        std::fprintf(stderr, "fuzz_page_commands: broken expectation: %s\n", what);
        std::abort();
      }
  }

  bool same_number(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0 || (a != a && b != b); }

  // The command as the page writes it (view/web/view.js), every number exactly (%.17g).
  std::string written(const PageCommand &c)
  {
    char text[256];
    if (c.verb == PageCommand::release)
      std::snprintf(text, sizeof text, "release %u", unsigned(c.hip));
    else if (c.verb == PageCommand::press)
      std::snprintf(text, sizeof text, "press %u %u %.17g", unsigned(c.hip), unsigned(c.vertex), c.force);
    else
      std::snprintf(text, sizeof text, "slide %u %u %.17g %.17g %.17g %.17g", unsigned(c.hip), unsigned(c.vertex),
                    c.point[0], c.point[1], c.point[2], c.force);
    return text;
  }

  void parse_as(const char *data, std::size_t size, bool sliding)
  {
    PageCommand       command;
    const std::string error = modalrt_view::parse_page_command(data, size, hips, vertices, sliding, command);
    if (!error.empty())
      {
        expect(error.rfind("error: '", 0) == 0, "a refusal starts with \"error: '\"");
        expect(error.size() < 400, "a refusal is short");
        for (unsigned char c : error)
          expect(c >= 0x20 && c < 0x7f, "a refusal is printable ASCII");
        return;
      }
    expect(command.hip < hips, "an accepted HIP is in range");
    expect(command.verb == PageCommand::release || command.vertex < vertices, "an accepted vertex is in range");
    expect(sliding || command.verb != PageCommand::slide, "a slide needs sliding contacts");
    const std::string text = written(command);
    PageCommand       again;
    expect(modalrt_view::parse_page_command(text.data(), text.size(), hips, vertices, sliding, again).empty(),
           "an accepted command, written out, is accepted");
    expect(again.verb == command.verb && again.hip == command.hip, "it names the same verb and HIP");
    if (command.verb == PageCommand::release)
      return;
    expect(again.vertex == command.vertex && same_number(again.force, command.force), "the same vertex and force");
    for (int d = 0; d < 3; ++d)
      expect(same_number(again.point[d], command.point[d]), "the same surface point");
  }
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
  const char *text = reinterpret_cast<const char *>(data);
  parse_as(text, size, false);
  parse_as(text, size, true);
  return 0;
}
