// The text of a parameter's default, written from the value in the struct it fills, so that each
// default is written once (scene_parameters.cc declares every entry with these). Plain C++17.
#pragma once

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace modal_haptics::parameter_text
{
  // How a default is printed: %g's choice (fixed notation for exponents -4 to 5), or always with
  // an exponent, for a tolerance that reads better as 1e-3 than as 0.001.
  enum class Notation
  {
    automatic,
    exponent
  };

  // The shortest text that reads back as `value`: fixed notation up to 6 significant digits
  // ("1050", "0.001"), a compact exponent beyond ("2.3e9", "2e-5").
  inline std::string text(const double value, const Notation notation = Notation::automatic)
  {
    char buffer[32];
    for (int digits = 6; digits <= 17; ++digits)
      {
        std::snprintf(buffer, sizeof buffer, notation == Notation::exponent ? "%.*e" : "%.*g",
                      notation == Notation::exponent ? digits - 6 : digits, value);
        if (std::strtod(buffer, nullptr) == value)
          break;
      }
    std::string out = buffer;
    const auto  e   = out.find('e');
    if (notation == Notation::exponent && out.find('.') != std::string::npos)
      {
        // "%.2e" pads the mantissa with zeros: 1.50e-03 -> 1.5e-03.
        const auto last = out.find_last_not_of('0', e - 1);
        out.erase(out[last] == '.' ? last : last + 1, e - (out[last] == '.' ? last : last + 1));
      }
    const auto e_at = out.find('e');
    if (e_at == std::string::npos)
      return out;
    const std::string sign     = out[e_at + 1] == '-' ? "-" : "";
    const auto        digits   = out.find_first_not_of("+-0", e_at + 1);
    const std::string exponent = digits == std::string::npos ? "0" : out.substr(digits);
    return out.substr(0, e_at + 1) + sign + exponent;
  }

  inline std::string text(const bool value) { return value ? "true" : "false"; }
  inline std::string text(const unsigned int value) { return std::to_string(value); }

  inline std::string text(const std::vector<double> &values)
  {
    std::string out;
    for (const double v : values)
      out += (out.empty() ? "" : ", ") + text(v);
    return out;
  }

  inline std::string text(const std::array<double, 3> &point) { return text(std::vector<double>(point.begin(), point.end())); }

  inline std::string text(const std::vector<std::string> &names)
  {
    std::string out;
    for (const auto &name : names)
      out += (out.empty() ? "" : ", ") + name;
    return out;
  }
} // namespace modal_haptics::parameter_text
