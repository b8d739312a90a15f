// The length unit a CAD file declares: a STEP file's LENGTH_UNIT entity (SI_UNIT with its prefix, or
// a CONVERSION_BASED_UNIT such as 'INCH'), an IGES file's global section (units flag, parameter 14).
// OpenCASCADE would convert every import to millimetres; the mesher asks it for the declared unit
// instead (Geometry.OCCTargetUnit), so the model's coordinates are the file's own numbers.
#include "mesher_parts.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <filesystem>
#include <sstream>

namespace modal_haptics::meshing
{
  using detail::lower_case;

  namespace
  {
    std::string upper_case_without_spaces(const std::string &text)
    {
      std::string out;
      for (const unsigned char c : text)
        if (!std::isspace(c))
          out += static_cast<char>(std::toupper(c));
      return out;
    }

    // The units OpenCASCADE can convert to (its names for Geometry.OCCTargetUnit), in metres.
    struct KnownUnit
    {
      const char *name;     // as printed
      const char *occ_code; // Geometry.OCCTargetUnit
      double      metres;
    };
    const KnownUnit known_units[] = {{"millimetre", "MM", 1e-3},  {"centimetre", "CM", 1e-2}, {"metre", "M", 1.},
                                     {"kilometre", "KM", 1e3},    {"micrometre", "UM", 1e-6}, {"inch", "INCH", 0.0254},
                                     {"foot", "FT", 0.3048},      {"mile", "MI", 1609.344},   {"mil", "MIL", 2.54e-5},
                                     {"microinch", "UIN", 2.54e-8}};

    DeclaredUnit unit_named(const std::string &name, const std::string &file, const std::string &declaration)
    {
      for (const auto &unit : known_units)
        if (name == unit.name)
          return {unit.name, unit.occ_code, unit.metres};
      throw MeshingError("geometry file '" + file + "' declares the length unit '" + declaration +
                         "', which OpenCASCADE cannot convert (known: millimetre, centimetre, metre, kilometre, "
                         "micrometre, inch, foot, mile, mil, microinch)");
    }

    std::string read_text(const std::string &file)
    {
      std::ifstream input(file, std::ios::binary);
      if (!input)
        throw MeshingError("geometry file '" + file + "' does not exist or cannot be read");
      std::ostringstream text;
      text << input.rdbuf();
      return text.str();
    }

    // The first entity instance of a STEP file that is a LENGTH_UNIT (simple or complex).
    DeclaredUnit step_unit(const std::string &file)
    {
      const std::string text = read_text(file);
      for (std::size_t at = text.find("LENGTH_UNIT"); at != std::string::npos; at = text.find("LENGTH_UNIT", at + 1))
        {
          if (at > 0 && (std::isalnum(static_cast<unsigned char>(text[at - 1])) || text[at - 1] == '_'))
            continue; // part of a longer name
          const std::size_t begin = text.rfind(';', at), end = text.find(';', at);
          const std::string entity =
            upper_case_without_spaces(text.substr(begin == std::string::npos ? 0 : begin + 1, end - begin));
          if (entity.find("LENGTH_UNIT(") == std::string::npos)
            continue;
          const std::size_t conversion = entity.find("CONVERSION_BASED_UNIT('");
          if (conversion != std::string::npos)
            {
              const std::size_t first = conversion + 23, last = entity.find('\'', first);
              std::string       name  = entity.substr(first, last - first);
              std::string       lower = lower_case(name);
              if (lower == "millimeter" || lower == "meter" || lower == "centimeter" || lower == "feet")
                lower = lower == "feet" ? "foot" : lower.substr(0, lower.size() - 2) + "re";
              return unit_named(lower, file, name);
            }
          const std::size_t si = entity.find("SI_UNIT(");
          if (si == std::string::npos || entity.find(".METRE.", si) == std::string::npos)
            continue;
          const std::string prefix = entity.substr(si + 8, entity.find(',', si) - si - 8);
          const std::string name   = prefix == "$" ? "metre" : lower_case(prefix.substr(1, prefix.size() - 2)) + "metre";
          return unit_named(name, file, "SI_UNIT(" + prefix + ",.METRE.)");
        }
      return {};
    }

    // Parameter 14 (units flag) and 15 (units name) of an IGES file's global section.
    DeclaredUnit iges_unit(const std::string &file)
    {
      std::istringstream lines(read_text(file));
      std::string        global, line;
      while (std::getline(lines, line))
        if (line.size() >= 73 && line[72] == 'G')
          global += line.substr(0, 72);
      char parameter_delimiter = ',', record_delimiter = ';';
      if (global.rfind("1H", 0) == 0 && global.size() > 2)
        parameter_delimiter = global[2];
      std::vector<std::string> parameters;
      std::size_t              at = 0;
      while (at < global.size() && parameters.size() < 15)
        {
          std::string value;
          // A Hollerith string nHxxx may hold delimiters: read its n characters as they are.
          std::size_t digits = at;
          while (digits < global.size() && std::isdigit(static_cast<unsigned char>(global[digits])))
            ++digits;
          if (digits > at && digits < global.size() && global[digits] == 'H')
            {
              const std::size_t n = std::stoul(global.substr(at, digits - at));
              value               = global.substr(digits + 1, n);
              at                  = digits + 1 + n;
            }
          while (at < global.size() && global[at] != parameter_delimiter && global[at] != record_delimiter)
            value += global[at++];
          ++at;
          parameters.push_back(value);
          if (parameters.size() == 2 && !parameters[1].empty())
            record_delimiter = parameters[1].back();
        }
      if (parameters.size() < 14)
        return {};
      const std::string flag_text = upper_case_without_spaces(parameters[13]);
      if (flag_text.empty())
        return {};
      static const char *by_flag[] = {"",     "inch",      "millimetre", "", "foot", "mile",
                                      "metre", "kilometre", "mil",        "micrometre", "centimetre", "microinch"};
      const int          flag      = std::atoi(flag_text.c_str());
      if (flag == 3 && parameters.size() == 15) // the unit given by name
        {
          const std::string name = upper_case_without_spaces(parameters[14]);
          const std::string lower = name == "IN" || name == "INCH" ? "inch" : name == "MM" ? "millimetre" :
                                    name == "M"  ? "metre" : name == "CM" ? "centimetre" : name == "FT" ? "foot" :
                                                                                                          lower_case(name);
          return unit_named(lower, file, "units flag 3, name '" + parameters[14] + "'");
        }
      if (flag < 1 || flag > 11 || flag == 3)
        throw MeshingError("geometry file '" + file + "': IGES units flag '" + parameters[13] + "' is not one of 1-11");
      return unit_named(by_flag[flag], file, "units flag " + std::to_string(flag));
    }
  } // namespace

  DeclaredUnit declared_length_unit(const std::string &file)
  {
    const std::string extension = detail::lower_case(std::filesystem::path(file).extension().string());
    if (extension == ".step" || extension == ".stp")
      return step_unit(file);
    if (extension == ".iges" || extension == ".igs")
      return iges_unit(file);
    return {};
  }
} // namespace modal_haptics::meshing
