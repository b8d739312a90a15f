#include "parameters/parameter_messages.h"

#include "parameters/parameter_text.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <vector>

namespace modal_haptics::parameter_messages
{
  using dealii::ExcMessage;
  using dealii::ParameterHandler;

  namespace
  {
    std::string trimmed(const std::string &text)
    {
      const auto first = text.find_first_not_of(" \t\r");
      return first == std::string::npos ? "" : text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
    }

    std::string joined(const std::vector<std::string> &names, const std::string &separator = ", ")
    {
      std::string out;
      for (const auto &name : names)
        out += (out.empty() ? "" : separator) + name;
      return out;
    }

    // The unit a description declares ("... Units: kg/m^3."), "" for none.
    std::string unit_in(const std::string &documentation)
    {
      const auto at = documentation.find("Units: ");
      if (at == std::string::npos)
        return "";
      const std::string rest = documentation.substr(at + 7);
      if (rest.rfind("geometry units", 0) == 0)
        return "geometry units, 'Geometry/Length unit' metres each";
      std::string unit = rest.substr(0, rest.find_first_of(" (;,"));
      while (!unit.empty() && unit.back() == '.')
        unit.pop_back();
      return unit == "none" ? "" : unit;
    }

    // What is declared, read back from the handler's own listing (PRM style: each entry's
    // documentation as comments above its 'set' line): per subsection path ("Scenario 1"; "" at the
    // top) its entries and subsections, and per entry path its unit.
    struct Declared
    {
      std::map<std::string, std::vector<std::string>> entries, subsections;
      std::map<std::string, std::string>              units;

      explicit Declared(const ParameterHandler &prm)
      {
        std::stringstream listing;
        prm.print_parameters(listing, ParameterHandler::PRM);
        std::vector<std::string> path;
        std::string              documentation;
        for (std::string line; std::getline(listing, line);)
          {
            line = trimmed(line);
            if (line.rfind("#", 0) == 0)
              documentation += " " + trimmed(line.substr(1));
            else if (line.rfind("subsection ", 0) == 0)
              {
                subsections[joined(path, "/")].push_back(trimmed(line.substr(11)));
                path.push_back(trimmed(line.substr(11)));
              }
            else if (line == "end" && !path.empty())
              path.pop_back();
            else if (line.rfind("set ", 0) == 0)
              {
                const std::string name = trimmed(line.substr(4, line.find('=') - 4));
                entries[joined(path, "/")].push_back(name);
                units[joined(path, "/") + "/" + name] = unit_in(documentation);
              }
            if (line.empty() || line[0] != '#')
              documentation.clear();
          }
      }
    };

    // The subsection path ("Scenario 1") that holds line 'line' (1-based) of a .prm file.
    std::string subsection_at(const std::string &file, const unsigned int line)
    {
      std::ifstream            in(file);
      std::vector<std::string> path;
      std::string              text;
      for (unsigned int n = 1; n < line && std::getline(in, text); ++n)
        {
          text = trimmed(text.substr(0, text.find('#')));
          if (text.rfind("subsection ", 0) == 0 || text.rfind("subsection\t", 0) == 0)
            path.push_back(trimmed(text.substr(11)));
          else if (text == "end" && !path.empty())
            path.pop_back();
        }
      return joined(path, "/");
    }

    std::string entry_path(const std::string &subsection, const std::string &name)
    {
      return subsection.empty() ? name : subsection + "/" + name;
    }

    // " Did you mean 'X'?" or the list of what there is.
    std::string suggestion(const std::string &name, const std::vector<std::string> &names, const std::string &kind)
    {
      const std::string closest = closest_name(name, names);
      if (!closest.empty())
        return " Did you mean '" + closest + "'?";
      return " Its " + kind + ": " + (names.empty() ? "none" : joined(names)) + ".";
    }

    std::string info_of(const dealii::ExceptionBase &e)
    {
      std::ostringstream text;
      e.print_info(text);
      return text.str();
    }

    // What deal.II's message holds after 'label' (to the end of the line, or up to the next '>'
    // after a '<'): its "Line <12>", "No entry with name <Colour>".
    std::string part_of(const std::string &message, const std::string &label)
    {
      const auto at = message.find(label);
      if (at == std::string::npos)
        return "";
      const auto begin = at + label.size();
      return trimmed(message.substr(begin, message.find_first_of(">\n", begin) - begin));
    }

    // The lines of deal.II's message after its first, trimmed: a refused value's value, name, pattern.
    std::vector<std::string> lines_of(const std::string &message)
    {
      std::vector<std::string> lines;
      std::istringstream       in(message);
      for (std::string line; std::getline(in, line);)
        lines.push_back(trimmed(line));
      return lines;
    }

    [[noreturn]] void refuse_value(const dealii::ExceptionBase &e, const std::string &file, const Declared &declared)
    {
      // "Line <N> of file <F>:", "The entry value", VALUE, "for the entry named", NAME, "does not
      // match the given pattern:", PATTERN.
      const std::string info    = info_of(e);
      const auto        lines   = lines_of(info);
      const std::string line    = part_of(info, "Line <");
      const std::string value   = lines.size() > 2 ? lines[2] : "?";
      const std::string name    = lines.size() > 4 ? lines[4] : "?";
      const std::string pattern = lines.size() > 6 ? lines[6] : "";
      const std::string path    = entry_path(subsection_at(file, std::stoi(line)), name);
      const auto        unit    = declared.units.find(path);
      throw ExcMessage(file + ", line " + line + ": '" + path + "' = " + value + ": " + allowed_values(pattern) +
                       (unit == declared.units.end() || unit->second.empty() ? "" : " (unit: " + unit->second + ")") +
                       ".");
    }

    // An entry or a subsection that is not declared where the file puts it: named with the closest
    // declared one, or the list of those there are.
    [[noreturn]] void refuse_name(const std::string &info, const std::string &file, const Declared &declared,
                                  const bool subsection)
    {
      const std::string line    = part_of(info, "Line <");
      const std::string section = subsection_at(file, std::stoi(line));
      std::string       name = subsection ? part_of(info, "subsection to be entered: ") : part_of(info, "name <");
      name                   = name.substr(name.rfind('.') + 1); // deal.II joins a subsection's path by '.'
      const auto &names      = subsection ? declared.subsections : declared.entries;
      const auto  found      = names.find(section);
      const auto  known      = found == names.end() ? std::vector<std::string>() : found->second;
      const std::string kind = subsection ? "subsection" : "entry";
      throw ExcMessage(file + ", line " + line + ": " +
                       (section.empty() ? "the file's top level" : "subsection '" + section + "'") + " has no " +
                       kind + " '" + name + "'." + suggestion(name, known, subsection ? "subsections" : "entries"));
    }
  } // namespace

  void parse_input(ParameterHandler &prm, const std::string &file)
  {
    try
      {
        prm.parse_input(file);
      }
    catch (const ParameterHandler::ExcInvalidEntryForPattern &e)
      {
        refuse_value(e, file, Declared(prm));
      }
    catch (const ParameterHandler::ExcCannotParseLine &e)
      {
        if (info_of(e).find("No entry with name <") == std::string::npos)
          throw;
        refuse_name(info_of(e), file, Declared(prm), false);
      }
    catch (const ParameterHandler::ExcNoSubsection &e)
      {
        refuse_name(info_of(e), file, Declared(prm), true);
      }
  }

  namespace
  {
    // "Geometry/Ribbed panel/Rib thicknesses" -> {"Geometry", "Ribbed panel"} and "Rib thicknesses".
    std::pair<std::vector<std::string>, std::string> split_entry_path(const std::string &path)
    {
      std::vector<std::string> parts;
      std::size_t              begin = 0;
      for (std::size_t slash; (slash = path.find('/', begin)) != std::string::npos; begin = slash + 1)
        parts.push_back(trimmed(path.substr(begin, slash - begin)));
      return {parts, trimmed(path.substr(begin))};
    }

    // The names declared under a subsection path ("" at the top).
    std::vector<std::string> names_under(const std::map<std::string, std::vector<std::string>> &names,
                                         const std::vector<std::string> &path)
    {
      const auto found = names.find(joined(path, "/"));
      return found == names.end() ? std::vector<std::string>() : found->second;
    }

    // Throws unless every subsection of the path and its entry are declared, naming the first one
    // that is not and the closest declared name.
    void require_declared(const Declared &declared, const std::vector<std::string> &subsections,
                          const std::string &name, const std::string &where)
    {
      std::vector<std::string> path;
      const auto               refuse = [&](const std::string &kind, const std::string &missing,
                                            const std::vector<std::string> &known, const std::string &kinds) {
        throw ExcMessage(where + ": " + (path.empty() ? "the file's top level" : "subsection '" + joined(path, "/") + "'") +
                         " has no " + kind + " '" + missing + "'." + suggestion(missing, known, kinds));
      };
      for (const auto &subsection : subsections)
        {
          const auto known = names_under(declared.subsections, path);
          if (std::find(known.begin(), known.end(), subsection) == known.end())
            refuse("subsection", subsection, known, "subsections");
          path.push_back(subsection);
        }
      const auto known = names_under(declared.entries, path);
      if (std::find(known.begin(), known.end(), name) == known.end())
        refuse("entry", name, known, "entries");
    }

    // The pattern's description in deal.II's "The string <V> does not match the given pattern <P>.".
    std::string refused_pattern(const dealii::ExceptionBase &e)
    {
      const std::string info  = info_of(e);
      const std::string label = "the given pattern <";
      const auto        at    = info.find(label);
      const auto        end   = info.rfind('>');
      return at == std::string::npos || end < at ? "" : info.substr(at + label.size(), end - at - label.size());
    }
  } // namespace

  void set_entry(ParameterHandler &prm, const std::string &path, const std::string &value, const std::string &where)
  {
    const Declared declared(prm);
    const auto [subsections, name] = split_entry_path(path);
    require_declared(declared, subsections, name, where);
    for (const auto &subsection : subsections)
      prm.enter_subsection(subsection);
    try
      {
        prm.set(name, value);
      }
    catch (const dealii::ExceptionBase &e)
      {
        for (std::size_t k = 0; k < subsections.size(); ++k)
          prm.leave_subsection();
        const auto unit = declared.units.find(entry_path(joined(subsections, "/"), name));
        throw ExcMessage(where + ": '" + entry_path(joined(subsections, "/"), name) + "' = " + value + ": " +
                         allowed_values(refused_pattern(e)) +
                         (unit == declared.units.end() || unit->second.empty() ? "" : " (unit: " + unit->second + ")") +
                         ".");
      }
    for (std::size_t k = 0; k < subsections.size(); ++k)
      prm.leave_subsection();
  }

  // ---- Patterns -----------------------------------------------------------------------------------
  OpenInterval::OpenInterval(const double lower, const double upper)
    : lower(lower)
    , upper(upper)
  {}

  bool OpenInterval::match(const std::string &text) const
  {
    std::istringstream in(text);
    double             x;
    in >> x;
    return !in.fail() && (in >> std::ws).eof() && x > lower && x < upper;
  }

  std::string OpenInterval::description(const OutputStyle) const
  {
    const auto end = [](const double x) {
      return x == std::numeric_limits<double>::max() ? std::string("MAX_DOUBLE") : parameter_text::text(x);
    };
    return "[Double " + end(lower) + "..." + end(upper) + " (exclusive)]";
  }

  std::unique_ptr<dealii::Patterns::PatternBase> OpenInterval::clone() const
  {
    return std::make_unique<OpenInterval>(lower, upper);
  }

  std::string allowed_values(const std::string &pattern)
  {
    std::smatch range;
    if (std::regex_match(pattern, range, std::regex(R"(\[(Double|Integer range) (\S+)\.\.\.(\S+) \((\w+)\)\])")))
      {
        const std::string what  = range[1] == "Double" ? "a number" : "an integer";
        const bool        open  = range[4] == "exclusive";
        const bool        below = range[2] != "-MAX_DOUBLE" && range[2] != "-2147483648";
        const bool        above = range[3] != "MAX_DOUBLE" && range[3] != "2147483647";
        if (below && above)
          return "must be " + what + " in " + (open ? "(" : "[") + std::string(range[2]) + ", " +
                 std::string(range[3]) + (open ? ")" : "]");
        if (below)
          return "must be " + what + (open ? " > " : " >= ") + std::string(range[2]);
        if (above)
          return "must be " + what + (open ? " < " : " <= ") + std::string(range[3]);
        return "must be " + what;
      }
    if (std::regex_match(pattern, range, std::regex(R"(\[Selection (.*?) ?\])")))
      {
        std::string names = range[1];
        std::replace(names.begin(), names.end(), '|', ',');
        return "must be one of " + std::regex_replace(names, std::regex(","), ", ");
      }
    if (pattern == "[Bool]")
      return "must be true or false";
    return "must match " + pattern;
  }

  std::string closest_name(const std::string &name, const std::vector<std::string> &names)
  {
    const auto lower = [](std::string s) {
      std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
      return s;
    };
    const std::string a = lower(name);
    std::string       best;
    std::size_t       best_distance = a.size() / 3 + 1;
    for (const auto &candidate : names)
      {
        const std::string        b = lower(candidate);
        std::vector<std::size_t> previous(b.size() + 1), current(b.size() + 1);
        for (std::size_t j = 0; j <= b.size(); ++j)
          previous[j] = j;
        for (std::size_t i = 1; i <= a.size(); ++i)
          {
            current[0] = i;
            for (std::size_t j = 1; j <= b.size(); ++j)
              current[j] = std::min({previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (a[i - 1] != b[j - 1])});
            std::swap(previous, current);
          }
        if (previous[b.size()] < best_distance)
          {
            best_distance = previous[b.size()];
            best          = candidate;
          }
      }
    return best;
  }
} // namespace modal_haptics::parameter_messages
