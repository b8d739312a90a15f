// The command line of every program (modal-precompute, modal-mesh, modal-rt and its commands): one
// table per command, each option declared once with its name, value kind, placeholder and one line
// of help. The usage line and --help are printed from the table, and every bad command line is
// refused the same way: a message naming the option and the value, exit status 2.
//
//   mrt::cli::OptionTable table("modal-rt verify", "replays the stored validation cases");
//   table.text("--basis", "FILE.mrt", "the basis file", [&](const std::string &v) { path = v; }).required();
//   table.number("--rate", "HZ", "the haptic rate [Hz]", {100, 20000, "Hz"}, [&](double v) { rate = v; })
//     .shown_default("1000");
//   if (const int status = mrt::cli::parse_command_line(table, argc - 1, argv + 1); status >= 0)
//     return status; // 0 after --help, 2 after a bad command line
//
// Header-only, C++17 standard library only, so that a stage that links no mrt object may include it.
// The kernel library (realtime/src) never parses a command line and never includes it.
#pragma once

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mrt::cli
{
  // A bad command line. The message names the option and the value as given.
  struct UsageError : std::runtime_error
  {
    using std::runtime_error::runtime_error;
  };

  // The values a number accepts, both ends included, and their unit as messages print it.
  struct Range
  {
    double      low   = -HUGE_VAL;
    double      high  = HUGE_VAL;
    const char *unit  = "";
    bool        whole = false; // an integer: a count, a port, a seed
  };

  // What follows an option on the command line.
  enum class Kind
  {
    flag,      // nothing
    text,      // one value, taken as written (a path, a name, a list the command reads itself)
    number,    // one finite number within its Range
    repeatable // one value, and the option may be given again (each value in turn)
  };

  // One row of the table. Options are named ("--rate"); a positional argument has an empty name and
  // is matched by its place among the arguments that are no option.
  struct Option
  {
    std::string name, placeholder, help;
    Kind        kind = Kind::flag;
    Range       range;
    std::string default_text; // as the usage prints it: "[--rate HZ (1000)]"; "" none
    bool        is_required = false;
    std::function<void()>                    take_flag;
    std::function<void(const std::string &)> take_text; // text, repeatable, and a positional's text
    std::function<void(double)>              take_number;

    Option &required()
    {
      is_required = true;
      return *this;
    }
    Option &shown_default(const std::string &text)
    {
      default_text = text;
      return *this;
    }
    bool positional() const { return name.empty(); }
  };

  // "%g" with every digit a whole number up to 2^32 needs (a seed's range, a port's).
  inline std::string number_text(double value)
  {
    char text[32];
    std::snprintf(text, sizeof text, "%.10g", value);
    return text;
  }

  // `text` read as a number for `option` within `range`; a UsageError naming both otherwise.
  inline double read_number(const std::string &option, const std::string &text, const Range &range)
  {
    char        *end   = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    const std::string quoted = option + " '" + text + "'";
    if (text.empty() || *end != '\0' || !std::isfinite(value))
      throw UsageError(quoted + " is not a number");
    if (range.whole && value != std::floor(value))
      throw UsageError(quoted + " is not a whole number");
    if (value < range.low || value > range.high)
      throw UsageError(quoted + " is out of range [" + number_text(range.low) + ", " + number_text(range.high) + "]" +
                       (*range.unit ? std::string(" ") + range.unit : std::string()));
    return value;
  }

  class OptionTable
  {
  public:
    // `command` as the usage line starts ("modal-rt run"); `summary`: one line of what it does.
    OptionTable(std::string command, std::string summary)
      : command_(std::move(command))
      , summary_(std::move(summary))
    {}

    Option &flag(const std::string &name, const std::string &help, std::function<void()> take)
    {
      Option &o   = add(name, "", help, Kind::flag);
      o.take_flag = std::move(take);
      return o;
    }
    Option &text(const std::string &name, const std::string &placeholder, const std::string &help,
                 std::function<void(const std::string &)> take)
    {
      Option &o   = add(name, placeholder, help, Kind::text);
      o.take_text = std::move(take);
      return o;
    }
    Option &number(const std::string &name, const std::string &placeholder, const std::string &help, Range range,
                   std::function<void(double)> take)
    {
      Option &o     = add(name, placeholder, help, Kind::number);
      o.range       = range;
      o.take_number = std::move(take);
      return o;
    }
    Option &repeatable(const std::string &name, const std::string &placeholder, const std::string &help,
                       std::function<void(const std::string &)> take)
    {
      Option &o   = add(name, placeholder, help, Kind::repeatable);
      o.take_text = std::move(take);
      return o;
    }
    // Positional arguments, in the order they are declared; a required one before any optional one.
    Option &positional(const std::string &placeholder, const std::string &help,
                       std::function<void(const std::string &)> take)
    {
      return text("", placeholder, help, std::move(take));
    }
    Option &positional(const std::string &placeholder, const std::string &help, Range range,
                       std::function<void(double)> take)
    {
      return number("", placeholder, help, range, std::move(take));
    }
    // A paragraph printed after the options by --help: what the options do together.
    void notes(const std::string &text) { notes_ = text; }

    const std::string         &command() const { return command_; }
    const std::string         &summary() const { return summary_; }
    const std::vector<Option> &options() const { return options_; }

    // Hands every argument to its option (arguments[0] is the first after the command). false when
    // --help (or -h) is among them: nothing is taken then. Throws UsageError.
    bool parse(int count, char *const *arguments) const;
    // "usage: COMMAND ..." wrapped at 100 columns: required arguments bare, the others in brackets
    // with their default.
    std::string usage() const;
    // The usage, the summary, one line per option (placeholder, help, range, default) and the notes.
    std::string help() const;

  private:
    Option &add(const std::string &name, const std::string &placeholder, const std::string &help, Kind kind)
    {
      options_.emplace_back();
      Option &o     = options_.back();
      o.name        = name;
      o.placeholder = placeholder;
      o.help        = help;
      o.kind        = kind;
      return o;
    }
    const Option *find(const std::string &name) const
    {
      for (const Option &o : options_)
        if (!o.positional() && o.name == name)
          return &o;
      return nullptr;
    }
    static bool is_help(const std::string &argument) { return argument == "--help" || argument == "-h"; }
    static void take(const Option &o, const std::string &value)
    {
      if (o.kind == Kind::number)
        o.take_number(read_number(o.positional() ? o.placeholder : o.name, value, o.range));
      else
        o.take_text(value);
    }

    std::string         command_, summary_, notes_;
    std::vector<Option> options_;
  };

  inline bool OptionTable::parse(int count, char *const *arguments) const
  {
    for (int k = 0; k < count; ++k)
      if (is_help(arguments[k]))
        return false;
    std::vector<const Option *> given;
    std::size_t                 next_positional = 0;
    auto                        was_given = [&given](const Option *o) {
      for (const Option *g : given)
        if (g == o)
          return true;
      return false;
    };
    for (int k = 0; k < count; ++k)
      {
        const std::string argument = arguments[k];
        if (argument.size() > 1 && argument[0] == '-' && !std::isdigit(static_cast<unsigned char>(argument[1])))
          {
            const Option *o = find(argument);
            if (!o)
              throw UsageError("unknown option '" + argument + "'");
            if (o->kind != Kind::repeatable && was_given(o))
              throw UsageError(argument + " is given twice");
            given.push_back(o);
            if (o->kind == Kind::flag)
              {
                o->take_flag();
                continue;
              }
            if (k + 1 >= count || std::string(arguments[k + 1]).rfind("--", 0) == 0)
              throw UsageError(argument + " needs a value (" + o->placeholder + ")");
            take(*o, arguments[++k]);
            continue;
          }
        const Option *o    = nullptr;
        std::size_t   seen = 0;
        for (const Option &candidate : options_)
          if (candidate.positional() && seen++ == next_positional)
            o = &candidate;
        if (!o)
          throw UsageError("unexpected argument '" + argument + "'");
        ++next_positional;
        given.push_back(o);
        take(*o, argument);
      }
    for (const Option &o : options_)
      if (o.is_required && !was_given(&o))
        throw UsageError("missing " + (o.positional() ? o.placeholder : o.name + " " + o.placeholder));
    return true;
  }

  inline std::string OptionTable::usage() const
  {
    const std::string lead = "usage: " + command_;
    std::string       text = lead, line = lead;
    auto              append = [&](const std::string &item) {
      if (line.size() + 1 + item.size() > 100)
        {
          line = std::string(lead.size(), ' ');
          text += "\n" + line;
        }
      text += " " + item;
      line += " " + item;
    };
    for (bool positional : {true, false})
      for (const Option &o : options_)
        if (o.positional() == positional)
          {
            std::string item = positional ? o.placeholder : o.name;
            if (!positional && o.kind != Kind::flag)
              item += " " + o.placeholder;
            if (!o.default_text.empty())
              item += " (" + o.default_text + ")";
            append(o.is_required ? item : "[" + item + "]" + (o.kind == Kind::repeatable ? "..." : ""));
          }
    return text + "\n";
  }

  inline std::string OptionTable::help() const
  {
    std::string text = usage() + "\n" + summary_ + "\n\n" + (options_.empty() ? "" : "arguments and options:\n");
    for (const Option &o : options_)
      {
        std::string left = o.positional() ? o.placeholder : o.name;
        if (!o.positional() && o.kind != Kind::flag)
          left += " " + o.placeholder;
        std::vector<std::string> facts;
        if (o.is_required)
          facts.push_back("required");
        if (o.kind == Kind::number && (std::isfinite(o.range.low) || std::isfinite(o.range.high)))
          facts.push_back(number_text(o.range.low) + " .. " + number_text(o.range.high) +
                          (*o.range.unit ? std::string(" ") + o.range.unit : std::string()));
        if (o.kind == Kind::repeatable)
          facts.push_back("may be given again");
        if (!o.default_text.empty())
          facts.push_back("default " + o.default_text);
        std::string line = o.help;
        for (std::size_t f = 0; f < facts.size(); ++f)
          line += (f == 0 ? " (" : "; ") + facts[f] + (f + 1 == facts.size() ? ")" : "");
        constexpr std::size_t column = 26;
        text += "  " + left + (left.size() + 2 < column ? std::string(column - 2 - left.size(), ' ')
                                                        : "\n" + std::string(column, ' ')) +
                line + "\n";
      }
    text += "  --help                  this text, then exit\n";
    return notes_.empty() ? text : text + "\n" + notes_ + (notes_.back() == '\n' ? "" : "\n");
  }

  // Prints a bad command line's message and the usage on stderr: "COMMAND: MESSAGE". Returns 2.
  inline int report_usage_error(const OptionTable &table, const std::string &message)
  {
    std::fprintf(stderr, "%s: %s\n%s(%s --help: every option)\n", table.command().c_str(), message.c_str(),
                 table.usage().c_str(), table.command().c_str());
    return 2;
  }

  // Parses in the way every program does: -1 to go on; 0 after --help (the help on stdout); 2 after
  // a bad command line (report_usage_error).
  inline int parse_command_line(const OptionTable &table, int count, char *const *arguments)
  {
    try
      {
        if (table.parse(count, arguments))
          return -1;
        std::fputs(table.help().c_str(), stdout);
        return 0;
      }
    catch (const UsageError &e)
      {
        return report_usage_error(table, e.what());
      }
  }
} // namespace mrt::cli
