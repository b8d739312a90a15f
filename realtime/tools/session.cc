#include "session.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

namespace modalrt_tool
{
  namespace
  {
    constexpr std::uint32_t max_hips = 16; // the kernel's largest HIP capacity

    const char *const header_text = "time,hip,event,x,y,z";

    std::string trim(const std::string &text)
    {
      const std::size_t first = text.find_first_not_of(" \t\r");
      if (first == std::string::npos)
        return std::string();
      return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
    }

    std::vector<std::string> split_fields(const std::string &line)
    {
      std::vector<std::string> fields;
      std::size_t              start = 0;
      for (;;)
        {
          const std::size_t comma = line.find(',', start);
          fields.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
          if (comma == std::string::npos)
            return fields;
          start = comma + 1;
        }
    }

    // Where a row comes from, to name it in every message.
    struct RowContext
    {
      const std::string &path;
      int                line;

      [[noreturn]] void fail(const std::string &what) const
      {
        throw SessionError(path + ":" + std::to_string(line) + ": " + what);
      }
    };

    double parse_number(const RowContext &at, const std::string &field, const char *column)
    {
      if (field.empty())
        at.fail(std::string("column '") + column + "' is empty (a number is expected)");
      char *end = nullptr;
      errno     = 0;
      const double value = std::strtod(field.c_str(), &end);
      if (end != field.c_str() + field.size())
        at.fail(std::string("column '") + column + "': '" + field + "' is not a number");
      if (!std::isfinite(value) || errno == ERANGE)
        at.fail(std::string("column '") + column + "': '" + field + "' is not a finite number");
      return value;
    }

    std::uint32_t parse_hip(const RowContext &at, const std::string &field)
    {
      char         *end   = nullptr;
      const long    value = std::strtol(field.c_str(), &end, 10);
      if (field.empty() || end != field.c_str() + field.size() || value < 0 || value >= long(max_hips))
        at.fail("hip '" + field + "' is not an integer in 0.." + std::to_string(max_hips - 1));
      return std::uint32_t(value);
    }

    void parse_xyz(const RowContext &at, const std::vector<std::string> &fields, double out[3])
    {
      static const char *const names[3] = {"x", "y", "z"};
      for (int d = 0; d < 3; ++d)
        out[d] = parse_number(at, std::size_t(3 + d) < fields.size() ? fields[3 + d] : std::string(), names[d]);
    }

    void require_no_xyz(const RowContext &at, const std::vector<std::string> &fields, const std::string &event)
    {
      for (std::size_t k = 3; k < fields.size(); ++k)
        if (!fields[k].empty())
          at.fail("event '" + event + "' takes no x, y, z (found '" + fields[k] + "')");
    }

    void add_key(Channel &channel, double time, const double value[3])
    {
      channel.keys.push_back(Key{time, {value[0], value[1], value[2]}});
    }

    std::vector<Channel> &per_hip(std::vector<Channel> &channels, std::uint32_t hip)
    {
      if (channels.size() <= hip)
        channels.resize(hip + 1);
      return channels;
    }

    // The `proxy` row: at time 0, once; x = mu_s and y = mu_d (both empty: the kernel's defaults),
    // 0 <= mu_d <= mu_s <= 10 (the kernel's ranges), no z.
    void parse_proxy(const RowContext &at, const std::vector<std::string> &fields, double time, Session &s)
    {
      if (time != 0.0)
        at.fail("the 'proxy' row sets the kernel's contact mode: its time must be 0 (found " + fields[0] + ")");
      if (s.proxy)
        at.fail("a second 'proxy' row (the session has one contact mode)");
      if (fields.size() > 5 && !fields[5].empty())
        at.fail("event 'proxy' takes x = static friction and y = dynamic friction, no z (found '" + fields[5] + "')");
      const bool given = fields.size() > 3 && !(fields[3].empty() && (fields.size() < 5 || fields[4].empty()));
      const modalrt_kernel_def defaults = modalrt_kernel_default_def();
      s.proxy            = true;
      s.static_friction  = given ? parse_number(at, fields[3], "x") : defaults.static_friction;
      s.dynamic_friction = given ? parse_number(at, fields.size() > 4 ? fields[4] : std::string(), "y")
                                 : defaults.dynamic_friction;
      if (!(s.static_friction <= 10.0 && s.dynamic_friction >= 0.0 && s.dynamic_friction <= s.static_friction))
        {
          char text[128];
          std::snprintf(text, sizeof text, "friction mu_s %g, mu_d %g: needs 0 <= mu_d <= mu_s <= 10", s.static_friction,
                        s.dynamic_friction);
          at.fail(text);
        }
    }

    // The events of two designs felt in turn: `design,A|B`; the blind mode's `trial`, `present,1|2`
    // and `answer,1|2` (its column x holds the choice).
    Event parse_design_event(const RowContext &at, const std::vector<std::string> &fields, double time)
    {
      const std::string &event  = fields[2];
      const std::string  choice = fields.size() > 3 ? fields[3] : std::string();
      for (std::size_t k = 4; k < fields.size(); ++k)
        if (!fields[k].empty())
          at.fail("event '" + event + "' takes one value in column x (found '" + fields[k] + "' after it)");
      Event e{time, 0, EventKind::trial, {0.0, 0.0, 0.0}, 0, at.line};
      if (event == "trial")
        {
          if (!choice.empty())
            at.fail("event 'trial' takes no value (found '" + choice + "')");
        }
      else if (event == "design")
        {
          if (choice != "A" && choice != "B")
            at.fail("event 'design' takes A or B in column x (found '" + choice + "')");
          e.kind   = EventKind::design;
          e.choice = choice == "B" ? 1 : 0;
        }
      else
        {
          if (choice != "1" && choice != "2")
            at.fail("event '" + event + "' takes slot 1 or 2 in column x (found '" + choice + "')");
          e.kind   = event == "present" ? EventKind::present : EventKind::answer;
          e.choice = choice == "2" ? 2 : 1;
        }
      return e;
    }

    // One data row: appended to the session's channels or events.
    void parse_row(const RowContext &at, const std::vector<std::string> &fields, Session &s, double &last_time,
                   bool &ended)
    {
      if (fields.size() < 3 || fields.size() > 6)
        at.fail("expected 3 to 6 comma-separated fields (" + std::string(header_text) + "), found " +
                std::to_string(fields.size()));
      if (ended)
        at.fail("row after the 'end' row");
      const double time = parse_number(at, fields[0], "time");
      if (time < 0.0)
        at.fail("time " + fields[0] + " s is negative");
      if (time < last_time)
        at.fail("time " + fields[0] + " s is before the previous row's (rows must be in time order)");
      last_time = time;

      const std::string &event    = fields[2];
      const bool         hip_free = event == "frame" || event == "end" || event == "proxy" || event == "design" ||
                            event == "trial" || event == "present" || event == "answer";
      if (hip_free && !(fields[1].empty() || fields[1] == "-"))
        at.fail("event '" + event + "' belongs to no HIP: put '-' in column 'hip' (found '" + fields[1] + "')");
      double xyz[3] = {0.0, 0.0, 0.0};
      if (event == "target" || event == "force" || event == "press")
        {
          const std::uint32_t hip = parse_hip(at, fields[1]);
          parse_xyz(at, fields, xyz);
          s.hip_count = std::max(s.hip_count, hip + 1);
          if (event == "target")
            add_key(per_hip(s.targets, hip)[hip], time, xyz);
          else if (event == "force")
            add_key(per_hip(s.forces, hip)[hip], time, xyz);
          else
            s.events.push_back(Event{time, hip, EventKind::press, {xyz[0], xyz[1], xyz[2]}, 0, at.line});
        }
      else if (event == "release")
        {
          const std::uint32_t hip = parse_hip(at, fields[1]);
          require_no_xyz(at, fields, event);
          s.hip_count = std::max(s.hip_count, hip + 1);
          s.events.push_back(Event{time, hip, EventKind::release, {0.0, 0.0, 0.0}, 0, at.line});
        }
      else if (event == "frame")
        {
          parse_xyz(at, fields, xyz);
          add_key(s.frame, time, xyz);
        }
      else if (event == "end")
        {
          require_no_xyz(at, fields, event);
          s.end_time = time;
          ended      = true;
        }
      else if (event == "proxy")
        parse_proxy(at, fields, time, s);
      else if (event == "design" || event == "trial" || event == "present" || event == "answer")
        s.events.push_back(parse_design_event(at, fields, time));
      else
        at.fail("unknown event '" + event + "' (expected target, force, press, release, frame, proxy, end, design, "
                "trial, present or answer)");
    }

    // Every HIP the session names needs a starting position: its first target key.
    void check_complete(Session &s, double last_time, bool ended)
    {
      s.targets.resize(s.hip_count);
      s.forces.resize(s.hip_count);
      if (s.hip_count == 0)
        throw SessionError(s.path + ": the session names no HIP (no target, force, press or release row)");
      for (std::uint32_t h = 0; h < s.hip_count; ++h)
        if (s.targets[h].empty())
          throw SessionError(s.path + ": HIP " + std::to_string(h) +
                             " has no 'target' row (every HIP needs one: its starting position)");
      if (!ended)
        s.end_time = last_time;
      if (!(s.end_time > 0.0))
        throw SessionError(s.path + ": the session lasts 0 s (add rows with later times or an 'end' row)");
    }
  } // namespace

  Session read_session(const std::string &path)
  {
    std::ifstream file(path);
    if (!file)
      throw SessionError("cannot open session file '" + path + "': " + std::strerror(errno));
    Session s;
    s.path          = path;
    bool   header   = false, ended = false;
    double last_time = 0.0;
    int    line_number = 0;
    for (std::string line; std::getline(file, line);)
      {
        ++line_number;
        const std::string text = trim(line.substr(0, line.find('#'))); // '#' starts a comment
        if (text.empty())
          continue;
        const RowContext at{path, line_number};
        if (!header)
          {
            std::string compact;
            for (char c : text)
              if (c != ' ' && c != '\t')
                compact += c;
            if (compact != header_text)
              at.fail("the first line must be the header '" + std::string(header_text) + "', found '" + text + "'");
            header = true;
            continue;
          }
        parse_row(at, split_fields(text), s, last_time, ended);
      }
    if (!header)
      throw SessionError(path + ": empty session file (no header '" + std::string(header_text) + "')");
    check_complete(s, last_time, ended);
    return s;
  }

  DesignEventCount count_design_events(const Session &session)
  {
    DesignEventCount count;
    for (const Event &e : session.events)
      {
        count.design += e.kind == EventKind::design;
        count.trial += e.kind == EventKind::trial;
        count.present += e.kind == EventKind::present;
        count.answer += e.kind == EventKind::answer;
      }
    return count;
  }

  double resolve_press_vertices(Session &session, const double *vertices, std::uint32_t vertex_count,
                                bool second_design)
  {
    double worst = 0.0;
    for (Event &e : session.events)
      {
        if (e.kind != EventKind::press)
          continue;
        double best = std::numeric_limits<double>::infinity();
        for (std::uint32_t v = 0; v < vertex_count; ++v)
          {
            const double *x = vertices + 3 * std::size_t(v);
            const double  d = (x[0] - e.point[0]) * (x[0] - e.point[0]) + (x[1] - e.point[1]) * (x[1] - e.point[1]) +
                             (x[2] - e.point[2]) * (x[2] - e.point[2]);
            if (d < best)
              {
                best                                 = d;
                (second_design ? e.vertex_b : e.vertex) = v;
              }
          }
        worst = std::max(worst, std::sqrt(best));
      }
    return worst;
  }

  void sample(const Channel &channel, double t, std::size_t &cursor, ChannelSample &out)
  {
    for (int d = 0; d < 3; ++d)
      out.value[d] = channel.default_value[d], out.velocity[d] = 0.0, out.acceleration[d] = 0.0;
    const std::vector<Key> &keys = channel.keys;
    if (keys.empty())
      return;
    while (cursor + 1 < keys.size() && keys[cursor + 1].time <= t)
      ++cursor;
    const Key &a = keys[cursor];
    if (t <= a.time || cursor + 1 == keys.size())
      {
        for (int d = 0; d < 3; ++d)
          out.value[d] = a.value[d]; // before the first key or after the last: hold
        return;
      }
    // Minimum-jerk blend s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5: starts and ends at rest.
    const Key   &b   = keys[cursor + 1];
    const double span = b.time - a.time, tau = (t - a.time) / span;
    const double s   = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
    const double ds  = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / span;
    const double dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / (span * span);
    for (int d = 0; d < 3; ++d)
      {
        const double step   = b.value[d] - a.value[d];
        out.value[d]        = a.value[d] + step * s;
        out.velocity[d]     = step * ds;
        out.acceleration[d] = step * dds;
      }
  }
} // namespace modalrt_tool
