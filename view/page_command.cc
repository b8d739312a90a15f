#include "page_command.h"

#include <cstdlib>
#include <sstream>

namespace modalrt_view
{
  std::string quoted_page_message(const char *bytes, std::size_t size)
  {
      constexpr std::size_t longest = 80;
      std::string           text  = "'";
      for (std::size_t i = 0; i < size && i < longest; ++i)
        {
          const unsigned char c = static_cast<unsigned char>(bytes[i]);
          text += c >= 0x20 && c < 0x7f ? char(c) : '?';
        }
      return text + (size > longest ? "...'" : "'");
  }

  std::string parse_page_command(const char *bytes, std::size_t size, std::uint32_t hips, std::uint32_t vertices,
                                 bool sliding, PageCommand &command)
  {
    std::istringstream in(std::string(bytes, size));
    std::string        verb;
    unsigned long      hip = 0;
    in >> verb >> hip;
    const std::string hip_limit = " with HIP < " + std::to_string(hips);
    if (!in || hip >= hips)
      return "error: " + quoted_page_message(bytes, size) +
             ": expected 'press HIP VERTEX FORCE', 'slide HIP VERTEX X Y Z FORCE' or 'release HIP'" + hip_limit;
    command     = PageCommand{};
    command.hip = std::uint32_t(hip);
    if (verb == "release")
      return "";
    if (verb != "press" && verb != "slide")
      return "error: " + quoted_page_message(bytes, size) +
             ": expected 'press HIP VERTEX FORCE', 'slide HIP VERTEX X Y Z FORCE' or 'release HIP'";
    const bool slide = verb == "slide";
    if (slide && !sliding)
      return "error: " + quoted_page_message(bytes, size) + ": sliding needs sliding contacts (modal-rt view --contact proxy)";
    unsigned long vertex = 0;
    std::string   force_text;
    in >> vertex;
    if (slide)
      in >> command.point[0] >> command.point[1] >> command.point[2];
    in >> force_text;
    if (!in || vertex >= vertices)
      return "error: " + quoted_page_message(bytes, size) + ": expected " +
             (slide ? "'slide HIP VERTEX X Y Z FORCE'" : "'press HIP VERTEX FORCE'") + " with VERTEX < " +
             std::to_string(vertices);
    command.verb   = slide ? PageCommand::slide : PageCommand::press;
    command.vertex = std::uint32_t(vertex);
    command.force  = std::strtod(force_text.c_str(), nullptr);
    return "";
  }
} // namespace modalrt_view
