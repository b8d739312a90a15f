#include "run_command.h"

#include "haptic_scale.h"

#include "devices.h"
#include "run_loop.h"
#include "run_outputs.h"
#include "session.h"
#include "stiffness_map.h"
#include "udp_device.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <arpa/inet.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

namespace modalrt_tool
{
  namespace
  {
    constexpr double        min_rate = 100.0, max_rate = 20000.0; // [Hz]
    constexpr std::uint64_t max_ticks = 20000000;                  // bounds the per-tick arrays (160 MB)
    constexpr double        display_rate = 60.0;                   // [Hz]
    constexpr double        default_serve_duration = 600.0;        // [s]

    struct RunOptions
    {
      bool        serve = false; // `serve`: a UDP device and no session; else `run`
      std::string basis, session, output_dir;
      double      rate          = 1000.0; // [Hz]
      double      duration      = -1.0;   // [s] < 0: the session's end (serve: 600 s)
      bool        impedance     = true;
      DeviceKind  device        = DeviceKind::hand;
      double      frame_rate    = 10.0;  // [Hz] of simulated time (serve: 0, no frames)
      double      trace_rate    = 100.0; // [Hz] of simulated time
      double      snap_distance = -1.0;  // [m] < 0: automatic
      double      spin_us       = 100.0; // [us] spin before each deadline
      double      hold          = modalrt_kernel_default_def().fail_safe_hold; // [s]
      double      ramp          = modalrt_kernel_default_def().fail_safe_ramp; // [s]
      bool        quiet         = false;
      bool        plot          = true;  // force_displacement.png (needs /usr/bin/python3 and matplotlib)
      bool        help          = false;
      UdpSettings udp;                   // serve only
      bool        proxy         = false; // serve: --contact proxy, an app's session (run: the session's `proxy` row)
      double      static_friction  = modalrt_kernel_default_def().static_friction;  // serve: --friction
      double      dynamic_friction = modalrt_kernel_default_def().dynamic_friction;
      std::uint32_t validity_level = 5;  // [%] --validity-level: MODALRT_HIP_BEYOND_VALIDITY's level
      bool        validity_clamp = false; // --validity-clamp: the rendered force held at the validity force
      int         view_port     = -1;    // --view P: the browser view on loopback port P (0: any)
      WatchStarter watch        = nullptr; // what serves --view (null: built without the view)
      const DeviceSession *app  = nullptr; // an app's own device and view: no session file, no outputs
      std::string command;                 // run, serve, or the app's command
      std::string profile;                 // --device NAME / --profile NAME: a device profile ("": none)
      double      haptic_scale  = 0.0;     // --haptic-scale: s (0: from the profile and the scene)
      std::string design_b;                // --design-b FILE.mrt: a second design felt in turn ("": none)
      double      fade          = 0.25;    // [s] --fade: from one design to the other
      bool        blind         = false;   // --blind SEED: the session's trials in random order
      std::uint32_t blind_seed  = 0;
    };

    // A bad command line: one message naming the option and the value.
    struct UsageError
    {
      std::string message;
    };

    double number_option(const std::string &option, const char *text, double low, double high, const char *unit)
    {
      char        *end   = nullptr;
      const double value = std::strtod(text, &end);
      if (end == text || *end != '\0' || !std::isfinite(value))
        throw UsageError{option + ": '" + text + "' is not a number"};
      if (value < low || value > high)
        {
          char range[128];
          std::snprintf(range, sizeof range, " is out of range [%g, %g] %s", low, high, unit);
          throw UsageError{option + " " + text + range};
        }
      return value;
    }

    std::uint32_t integer_option(const std::string &option, const char *text, double low, double high)
    {
      const double value = number_option(option, text, low, high, "");
      if (value != std::floor(value))
        throw UsageError{option + ": '" + text + "' is not an integer"};
      return std::uint32_t(value);
    }

    // A value that is one of two words: true for the first; otherwise a usage error naming both.
    bool first_of_two(const std::string &option, const char *value, const char *first, const char *second)
    {
      const std::string text = value;
      if (text != first && text != second)
        throw UsageError{option + " '" + text + "' is not " + first + " or " + second};
      return text == first;
    }

    // Every option of `run` and `serve` in one table: its name, the commands that take it, its value
    // (null for a flag), its default as the usage prints it, and what it sets. A new option is one
    // row here.
    enum : unsigned
    {
      for_run   = 1u,
      for_serve = 2u,
      for_both  = 3u
    };
    struct OptionSpec
    {
      const char *name;
      unsigned    commands;
      const char *value;        // "HZ", "FILE.mrt", ...; nullptr: a flag without a value
      const char *shown_default; // nullptr: none printed; "!": required
      void (*apply)(RunOptions &o, const std::string &option, const char *value);
    };

    const OptionSpec option_table[] = {
      {"--basis", for_both, "FILE.mrt", "!", [](RunOptions &o, const std::string &, const char *v) { o.basis = v; }},
      {"--session", for_run, "SESSION.csv", "!",
       [](RunOptions &o, const std::string &, const char *v) { o.session = v; }},
      {"--output-dir", for_both, "DIR", "!", [](RunOptions &o, const std::string &, const char *v) { o.output_dir = v; }},
      {"--bind", for_serve, "ADDRESS", "127.0.0.1",
       [](RunOptions &o, const std::string &n, const char *v) {
         in_addr address{};
         if (inet_pton(AF_INET, v, &address) != 1)
           throw UsageError{n + ": '" + v + "' is not an IPv4 address"};
         o.udp.bind_address = v;
       }},
      {"--port", for_serve, "N", "47000",
       [](RunOptions &o, const std::string &n, const char *v) { o.udp.port = std::uint16_t(integer_option(n, v, 1, 65535)); }},
      {"--hips", for_serve, "N", "1",
       [](RunOptions &o, const std::string &n, const char *v) { o.udp.hips = integer_option(n, v, 1, udp::max_hips); }},
      {"--peer-timeout", for_serve, "S", "1",
       [](RunOptions &o, const std::string &n, const char *v) { o.udp.peer_timeout = number_option(n, v, 1e-3, 3600, "s"); }},
      {"--token", for_serve, "HEX", nullptr, // the device's secret (realtime/README.md); default: 128 random bits
       [](RunOptions &o, const std::string &n, const char *v) {
         if (!udp::parse_token(v, o.udp.token))
           throw UsageError{n + " is not " + std::to_string(2 * udp::token_size) + " hexadecimal digits"};
         o.udp.token_given = true;
       }},
      {"--token-file", for_serve, "PATH", "$XDG_RUNTIME_DIR/modal-rt/serve-PORT.token",
       [](RunOptions &o, const std::string &, const char *v) { o.udp.token_file = v; }},
      {"--contact", for_serve, "snap|proxy", "snap", // run: the session's `proxy` row
       [](RunOptions &o, const std::string &n, const char *v) { o.proxy = !first_of_two(n, v, "snap", "proxy"); }},
      {"--friction", for_serve, "MU_S,MU_D", "0.3,0.2",
       [](RunOptions &o, const std::string &n, const char *v) {
         std::string error;
         if (!parse_friction(v, o.static_friction, o.dynamic_friction, error))
           throw UsageError{n + " " + error};
       }},
      {"--rate", for_both, "HZ", "1000",
       [](RunOptions &o, const std::string &n, const char *v) { o.rate = number_option(n, v, min_rate, max_rate, "Hz"); }},
      {"--duration", for_both, "S", nullptr,
       [](RunOptions &o, const std::string &n, const char *v) { o.duration = number_option(n, v, 1e-3, 1e6, "s"); }},
      {"--mode", for_both, "impedance|admittance", "impedance",
       [](RunOptions &o, const std::string &n, const char *v) { o.impedance = first_of_two(n, v, "impedance", "admittance"); }},
      {"--device", for_run, "hand|probe|PROFILE", "hand", // PROFILE: the simulated hand on that device
       [](RunOptions &o, const std::string &n, const char *v) {
         modalrt_device_def spec;
         if (modalrt_device_profile_find(v, &spec) == MODALRT_OK)
           {
             o.device  = DeviceKind::hand;
             o.profile = v;
             return;
           }
         o.device = first_of_two(n, v, "hand", "probe") ? DeviceKind::hand : DeviceKind::probe;
       }},
      {"--profile", for_both, "touch|omni|desktop|falcon|omega.x|sigma.7|lambda.7|admittance", nullptr,
       [](RunOptions &o, const std::string &, const char *v) { o.profile = v; }},
      {"--haptic-scale", for_both, "S", nullptr,
       [](RunOptions &o, const std::string &n, const char *v) { o.haptic_scale = number_option(n, v, 1e-9, 1e3, ""); }},
      {"--hold", for_both, "S", "0.5",
       [](RunOptions &o, const std::string &n, const char *v) { o.hold = number_option(n, v, 0.0, 10.0, "s"); }},
      {"--ramp", for_both, "S", "0.05",
       [](RunOptions &o, const std::string &n, const char *v) { o.ramp = number_option(n, v, 1e-6, 10.0, "s"); }},
      {"--frame-rate", for_both, "HZ", "run 10, serve 0",
       [](RunOptions &o, const std::string &n, const char *v) { o.frame_rate = number_option(n, v, 0.0, display_rate, "Hz"); }},
      {"--trace-rate", for_both, "HZ", "100",
       [](RunOptions &o, const std::string &n, const char *v) { o.trace_rate = number_option(n, v, 1e-3, max_rate, "Hz"); }},
      {"--snap-distance", for_both, "M", nullptr,
       [](RunOptions &o, const std::string &n, const char *v) { o.snap_distance = number_option(n, v, 1e-6, 1.0, "m"); }},
      {"--spin-us", for_both, "US", "100",
       [](RunOptions &o, const std::string &n, const char *v) { o.spin_us = number_option(n, v, 0.0, 1e6, "us"); }},
      {"--validity-level", for_both, "1|5|10", "5", // the validity map's departure level (modalrt_kernel_def)
       [](RunOptions &o, const std::string &n, const char *v) {
         const std::string text = v;
         if (text != "1" && text != "5" && text != "10")
           throw UsageError{n + " '" + text + "' is not 1, 5 or 10 (percent)"};
         o.validity_level = std::uint32_t(std::stoul(text));
       }},
      {"--design-b", for_both, "FILE.mrt", nullptr, // a second design: the session's `design` rows, serve's flag
       [](RunOptions &o, const std::string &, const char *v) { o.design_b = v; }},
      {"--fade", for_both, "S", "0.25",
       [](RunOptions &o, const std::string &n, const char *v) { o.fade = number_option(n, v, 1e-3, 10.0, "s"); }},
      {"--blind", for_run, "SEED", nullptr, // the trials' order drawn from SEED; blind.csv logs the answers
       [](RunOptions &o, const std::string &n, const char *v) {
         o.blind      = true;
         o.blind_seed = integer_option(n, v, 0, 4294967295.0);
       }},
      {"--validity-clamp", for_both, nullptr, nullptr,
       [](RunOptions &o, const std::string &, const char *) { o.validity_clamp = true; }},
      {"--view", for_both, "PORT", nullptr, // the browser view on loopback port PORT (0: any free port), view/README.md
       [](RunOptions &o, const std::string &n, const char *v) { o.view_port = int(integer_option(n, v, 0, 65535)); }},
      {"--no-plot", for_both, nullptr, nullptr, [](RunOptions &o, const std::string &, const char *) { o.plot = false; }},
      {"--quiet", for_both, nullptr, nullptr, [](RunOptions &o, const std::string &, const char *) { o.quiet = true; }},
      {"--help", for_both, nullptr, nullptr, [](RunOptions &o, const std::string &, const char *) { o.help = true; }},
    };

    std::string usage_text(bool serve)
    {
      const unsigned command = serve ? for_serve : for_run;
      std::string    text    = serve ? "modal-rt serve" : "modal-rt run", line = text;
      for (const OptionSpec &spec : option_table)
        {
          if (!(spec.commands & command))
            continue;
          std::string item = spec.name;
          if (spec.value)
            item += std::string(" ") + spec.value;
          const bool required = spec.shown_default && std::string(spec.shown_default) == "!";
          if (spec.shown_default && !required)
            item += std::string(" (") + spec.shown_default + ")";
          if (!required)
            item = "[" + item + "]";
          if (line.size() + 1 + item.size() > 100)
            {
              text += "\n";
              line = std::string(20, ' ');
              text += line;
            }
          text += " " + item;
          line += " " + item;
        }
      return "       " + text + "\n";
    }

    RunOptions parse_options(int argc, char **argv, bool serve)
    {
      RunOptions o;
      o.serve      = serve;
      o.frame_rate = serve ? 0.0 : 10.0; // serve runs for minutes by default: no frames unless asked
      for (int k = 0; k < argc; ++k)
        {
          const std::string option = argv[k];
          const OptionSpec *spec   = nullptr;
          for (const OptionSpec &candidate : option_table)
            if (option == candidate.name && (candidate.commands & (serve ? for_serve : for_run)))
              spec = &candidate;
          if (!spec)
            throw UsageError{option.rfind("--", 0) == 0 ? "unknown option '" + option + "'"
                                                         : "unexpected argument '" + option + "'"};
          if (spec->value && k + 1 >= argc)
            throw UsageError{option + " needs a value"};
          spec->apply(o, option, spec->value ? argv[++k] : nullptr);
          if (o.help)
            return o;
        }
      if (o.basis.empty())
        throw UsageError{"missing --basis"};
      if (o.session.empty() && !serve)
        throw UsageError{"missing --session"};
      if (o.output_dir.empty())
        throw UsageError{"missing --output-dir"};
      if (o.blind && o.design_b.empty())
        throw UsageError{"--blind needs --design-b (the second design of the trials)"};
      if (!o.design_b.empty() && o.view_port >= 0)
        throw UsageError{"--view shows one design: it cannot be given with --design-b"};
      o.udp.rate = o.rate;
      return o;
    }

    // Longest edge of the display triangles [m]: a HIP anywhere on the surface is that close to a
    // vertex, so snapping needs at least that search radius.
    double longest_display_edge(const modalrt_basis *basis)
    {
      modalrt_basis_info info;
      modalrt_basis_get_info(basis, &info);
      const double   *x = modalrt_basis_display_vertices(basis);
      const uint32_t *t = modalrt_basis_display_triangles(basis);
      double          longest = 0.0;
      for (std::uint32_t k = 0; k < 3 * info.display_triangle_count; ++k)
        {
          const std::uint32_t a = t[k], b = t[k - k % 3 + (k + 1) % 3];
          double              d2 = 0.0;
          for (int d = 0; d < 3; ++d)
            d2 += (x[3 * a + d] - x[3 * b + d]) * (x[3 * a + d] - x[3 * b + d]);
          longest = std::max(longest, std::sqrt(d2));
        }
      return longest;
    }

    // The kernel's definition for this device and rate. The coupling is the kernel's default
    // (1000 N/m, 2 N s/m) within the device's limits, and softened at low rates so that the
    // sampled-passivity condition K T / 2 < b + D holds with a 10 % margin.
    modalrt_kernel_def kernel_def(const RunOptions &o, const DeviceSpec &spec, const modalrt_basis *basis,
                                  const Session &session)
    {
      modalrt_kernel_def def      = modalrt_kernel_default_def();
      def.time_step               = 1.0 / o.rate;
      def.hip_capacity            = session.hip_count;
      def.device.max_force        = spec.max_force;
      def.device.max_stiffness    = spec.max_stiffness;
      def.device.max_damping      = spec.max_damping;
      def.device.physical_damping = spec.physical_damping;
      def.coupling_damping        = std::min(def.coupling_damping, spec.max_damping);
      const double passive        = 0.9 * 2.0 * (spec.physical_damping + def.coupling_damping) / def.time_step;
      def.coupling_stiffness      = std::min({def.coupling_stiffness, spec.max_stiffness, passive});
      def.fail_safe_hold          = o.hold;
      if (session.proxy) // the session's `proxy` row: sliding contacts
        {
          def.contact_mode     = MODALRT_CONTACT_PROXY;
          def.static_friction  = session.static_friction;
          def.dynamic_friction = session.dynamic_friction;
        }
      def.fail_safe_ramp          = o.ramp;
      def.validity_level          = o.validity_level;
      def.validity_clamp          = o.validity_clamp ? 1 : 0;
      def.snap_distance = o.snap_distance > 0.0 ? o.snap_distance : std::max(def.snap_distance, longest_display_edge(basis));
      std::string error;
      if (!o.profile.empty() && !apply_device_profile(o.profile, o.haptic_scale, o.impedance, basis, def, error))
        throw UsageError{"--device/--profile " + o.profile + ": " + error};
      return def;
    }

    // --output-dir and its frames/ (stale frames of an earlier run are removed: frames.pvd must
    // describe exactly the files beside it).
    bool prepare_output_dir(const std::string &dir, std::string &error)
    {
      namespace fs = std::filesystem;
      std::error_code code;
      fs::create_directories(fs::path(dir) / "frames", code);
      if (code)
        {
          error = "cannot create output directory '" + dir + "/frames': " + code.message();
          return false;
        }
      for (const fs::directory_entry &entry : fs::directory_iterator(fs::path(dir) / "frames", code))
        {
          const std::string name = entry.path().filename().string();
          if (name.rfind("frame_", 0) == 0 && entry.path().extension() == ".vtu")
            fs::remove(entry.path(), code);
        }
      return true;
    }

    int fail(const std::string &message)
    {
      std::fprintf(stderr, "modal-rt: %s\n", message.c_str());
      return 1;
    }

    bool write_outputs(const RunOptions &o, const RunReport &report, const HapticResult &haptic,
                       const DisplayResult &display, const modalrt_basis *basis, const modalrt_basis *design_b,
                       std::uint32_t hips, std::string &error)
    {
      if (o.blind && !write_blind_log(o.output_dir + "/blind.csv", haptic.trials, error))
        return false;
      return write_trace(o.output_dir + "/trace.csv", haptic, hips, basis, o.impedance, report.validity_level, error,
                         design_b) &&
             write_presses(o.output_dir + "/presses.csv", report.presses, o.impedance, report.validity_level, error,
                           report.mapping.force_scale) &&
             write_slides(o.output_dir + "/slides.csv", haptic.slides, report.slide_margins, report.validity_level,
                          report.space_names, error) &&
             write_pvd(o.output_dir + "/frames.pvd", display.frames, error) &&
             write_file_atomically(o.output_dir + "/stats.json", stats_json(report), error);
    }

    // force_displacement.png from trace.csv and presses.csv, and slide_stiffness.png from trace.csv and
    // slides.csv when the run slid. Optional: without Python and matplotlib (or with --no-plot) the
    // run still succeeds, and one line says how to draw it later. A stale picture of an earlier run is
    // removed first.
    bool draw_plot(const RunOptions &o, const std::string &script, const std::string &picture, bool wanted)
    {
      std::error_code code;
      std::filesystem::remove(o.output_dir + "/" + picture, code);
      if (!o.plot || !wanted)
        return false;
      std::string notice;
      const bool  written = plot_run(script, picture, o.output_dir, notice);
      if (!written)
        std::fprintf(stderr, "modal-rt: %s\n", notice.c_str());
      return written;
    }

    // The session a command plays: the file (run), or none: serve's device brings the motion of
    // --hips HIPs (600 s by default), an app's device the motion of its HIPs (until Ctrl-C by default).
    bool load_session(const RunOptions &o, Session &session)
    {
      if (o.serve || o.app)
        {
          session.path      = o.serve ? "(udp)" : "(" + o.command + ")";
          session.hip_count = o.serve ? o.udp.hips : 0; // an app's: its device's, once made
          session.end_time  = o.duration > 0.0 ? o.duration : o.serve ? default_serve_duration : 0.0;
          session.proxy            = o.proxy; // serve's --contact and --friction: what run's `proxy` row sets
          session.static_friction  = o.static_friction;
          session.dynamic_friction = o.dynamic_friction;
          return true;
        }
      try
        {
          session = read_session(o.session);
          return true;
        }
      catch (const SessionError &e)
        {
          fail(std::string("bad session: ") + e.what());
          return false;
        }
    }

    std::unique_ptr<Device> make_session_device(const RunOptions &o, const Session &session,
                                                const modalrt_basis *basis, const modalrt_basis_info &info)
    {
      if (o.app)
        return o.app->make_device(basis);
      if (!o.serve)
        return make_device(o.device, session, 1.0 / o.rate);
      UdpSettings settings = o.udp;
      park_position(info, settings.park); // before the first state: no contact
      return make_udp_device(settings);
    }

    // The basis, the device, the kernel defined for them, and the view watching the session.
    struct Live
    {
      ~Live()
      {
        view.reset(); // it reads the kernel: gone first
        device.reset();
        modalrt_kernel_destroy(kernel);
        modalrt_basis_destroy(basis);
        modalrt_kernel_destroy(second.kernel);
        modalrt_basis_destroy(const_cast<modalrt_basis *>(second.basis));
      }

      modalrt_basis               *basis  = nullptr;
      modalrt_kernel              *kernel = nullptr;
      SecondDesign                 second; // --design-b (none: no kernel)
      modalrt_basis_info           info{};
      std::unique_ptr<Device>      device;
      modalrt_kernel_def           def{};
      double                       press_distance = 0.0; // [m] the session's press points to their vertices
      std::unique_ptr<RunObserver> view;
    };

    // kernel_def for `basis` (a profile that does not fit the mode or the basis is refused here, with
    // its reason, once the basis is known). false after a message.
    bool define_kernel(const RunOptions &o, const Session &session, const DeviceSpec &spec, const modalrt_basis *basis,
                       modalrt_kernel_def &def)
    {
      try
        {
          def = kernel_def(o, spec, basis, session);
          return true;
        }
      catch (const UsageError &e)
        {
          fail(e.message);
          return false;
        }
    }

    // The session's design rows against the command line: `design` rows need --design-b and are not
    // blind; `trial`, `present`, `answer` need --blind. false after a message.
    bool check_design_events(const RunOptions &o, const Session &session)
    {
      const DesignEventCount count      = count_design_events(session);
      const bool             blind_rows = count.trial + count.present + count.answer > 0;
      const std::string      file       = "session '" + session.path + "'";
      std::string            problem;
      if (count.design > 0 && o.design_b.empty())
        problem = file + " has 'design' rows: give the second design with --design-b";
      else if (count.design > 0 && o.blind)
        problem = file + " names designs in 'design' rows: a blind session presents slots ('trial', 'present', "
                         "'answer' rows)";
      else if (blind_rows && !o.blind)
        problem = file + " has 'trial', 'present' or 'answer' rows: they need --blind SEED";
      else if (o.blind && count.trial == 0)
        problem = "--blind: " + file + " has no 'trial' row";
      if (!problem.empty())
        fail(problem);
      return problem.empty();
    }

    // The second design: its basis, the session's press points resolved on it, and its kernel defined
    // as the first's, with one haptic scale for both (the smaller: both designs' bands fit the device,
    // and the hand compares them on one scale). false after a message.
    bool open_second_design(const RunOptions &o, Session &session, Live &live)
    {
      modalrt_basis *basis = nullptr;
      if (modalrt_basis_load(o.design_b.c_str(), &basis) != MODALRT_OK)
        {
          fail("bad basis file '" + o.design_b + "' (--design-b): " + modalrt_last_error_message());
          return false;
        }
      live.second.basis = basis;
      live.second.fade  = o.fade;
      live.second.blind = o.blind;
      live.second.seed  = o.blind_seed;
      modalrt_basis_info info{};
      modalrt_basis_get_info(basis, &info);
      live.press_distance = std::max(live.press_distance, resolve_press_vertices(session, modalrt_basis_display_vertices(basis),
                                                                                 info.display_vertex_count, true));
      modalrt_kernel_def def;
      if (!define_kernel(o, session, live.device->spec(), basis, def))
        return false;
      if (def.haptic_scale > 0.0 && live.def.haptic_scale > 0.0)
        def.haptic_scale = live.def.haptic_scale = std::min(def.haptic_scale, live.def.haptic_scale);
      if (modalrt_kernel_create(basis, &def, &live.second.kernel) != MODALRT_OK)
        {
          fail(std::string("cannot create the kernel of '") + o.design_b + "': " + modalrt_last_error_message());
          return false;
        }
      return true;
    }

    // Loads the basis, makes and opens the device, creates the kernel for it. false after a message.
    bool open_live(const RunOptions &o, Session &session, Live &live)
    {
      if (modalrt_basis_load(o.basis.c_str(), &live.basis) != MODALRT_OK)
        {
          fail("bad basis file '" + o.basis + "': " + modalrt_last_error_message());
          return false;
        }
      modalrt_basis_get_info(live.basis, &live.info);
      live.press_distance =
        resolve_press_vertices(session, modalrt_basis_display_vertices(live.basis), live.info.display_vertex_count);
      live.device = make_session_device(o, session, live.basis, live.info);
      std::string error;
      if (!live.device->open(error))
        {
          fail("cannot open the device: " + error);
          return false;
        }
      session.hip_count = live.device->hip_count();
      if (!define_kernel(o, session, live.device->spec(), live.basis, live.def))
        return false;
      if (!o.design_b.empty() && !open_second_design(o, session, live))
        return false;
      if (modalrt_kernel_create(live.basis, &live.def, &live.kernel) != MODALRT_OK)
        {
          fail(std::string("cannot create the kernel: ") + modalrt_last_error_message());
          return false;
        }
      return true;
    }

    // --view P (the app's watch-only view), or the app's own view of its device.
    bool start_view(const RunOptions &o, Live &live, std::string &error)
    {
      const ViewContext context{live.basis, o.basis, live.kernel, live.device->hip_count(), o.command,
                                live.def.contact_mode == MODALRT_CONTACT_PROXY, live.def.validity_level,
                                live.def.validity_clamp != 0};
      if (o.app)
        live.view = o.app->start_view(context, error);
      else if (o.view_port < 0)
        return true;
      else if (!o.watch)
        error = "--view " + std::to_string(o.view_port) + ": " + built_without_view;
      else
        live.view = o.watch(context, unsigned(o.view_port), error);
      return live.view != nullptr;
    }

    RunReport make_report(const RunOptions &o, const Session &session, double duration, const Live &live,
                          const HapticResult &haptic, const DisplayResult &display)
    {
      RunReport report  = summarize(haptic, o.rate);
      report.command    = o.command;
      report.basis      = o.basis;
      report.session    = session.path;
      report.output_dir = o.output_dir;
      report.mode       = o.impedance ? "impedance" : "admittance";
      report.device     = o.profile.empty() ? live.device->spec().name : live.device->spec().name + " as " + o.profile;
      report.profile    = o.profile;
      modalrt_kernel_get_haptic_mapping(live.kernel, &report.mapping);
      report.scale_line = haptic_scale_line(o.profile, report.mapping, live.def);
      report.stopped_by = haptic.interrupted ? "signal" : "end of session";
      report.rate       = o.rate;
      report.duration   = duration;
      report.hips       = session.hip_count;
      modalrt_kernel_get_stats(live.kernel, &report.kernel);
      report.haptic             = &haptic;
      report.display            = &display;
      report.max_press_distance = live.press_distance;
      report.coupling_stiffness = live.def.coupling_stiffness;
      report.coupling_damping   = live.def.coupling_damping;
      report.snap_distance      = live.def.snap_distance;
      report.device_counters    = live.device->counters();
      report.space_names        = space_names(live.basis);
      report.validity_level     = live.def.validity_level;
      report.validity_clamp     = live.def.validity_clamp != 0;
      report.validity_map       = has_validity_map(live.basis);
      report.design_b           = o.design_b;
      report.design_fade        = o.fade;
      report.blind              = o.blind;
      report.blind_seed         = o.blind_seed;
      return report;
    }

    // Two designs: each design's presses from its own rows of the trace, against its own basis (a press
    // is cut where the design felt changes), in order of start.
    std::vector<Press> presses_of_both_designs(const RunOptions &o, const Session &session, const Live &live,
                                               const HapticResult &haptic, double force_scale)
    {
      std::vector<Press> presses;
      for (std::uint32_t design : {0u, 1u})
        {
          const modalrt_basis *basis = design == 0 ? live.basis : live.second.basis;
          for (Press p : find_presses(trace_of_design(haptic, session.hip_count, design), session.hip_count, basis,
                                      o.impedance, live.def.validity_level, force_scale))
            {
              p.design = design;
              presses.push_back(p);
            }
        }
      std::stable_sort(presses.begin(), presses.end(), [](const Press &a, const Press &b) { return a.start < b.start; });
      return presses;
    }

    // After the run: the files of --output-dir, the plot and the summary.
    int write_results(const RunOptions &o, const Session &session, double duration, const Live &live,
                      const HapticResult &haptic, const DisplayResult &display)
    {
      RunReport report = make_report(o, session, duration, live, haptic, display);
      if (live.second.kernel)
        report.presses = presses_of_both_designs(o, session, live, haptic, report.mapping.force_scale);
      else
        report.presses = find_presses(haptic, session.hip_count, live.basis, o.impedance, live.def.validity_level,
                                      report.mapping.force_scale);
      report.slide_margins = find_slide_margins(haptic, session.hip_count, live.basis, live.def.validity_level);
      std::string error;
      if (!write_outputs(o, report, haptic, display, live.basis, live.second.basis, session.hip_count, error))
        return fail(error);
      report.plot_written       = draw_plot(o, "plot_force_displacement.py", "force_displacement.png", true);
      report.slide_plot_written = draw_plot(o, "plot_slide_stiffness.py", "slide_stiffness.png", !haptic.slides.empty());
      if (!o.quiet)
        print_summary(report);
      if (!display.error.empty())
        return fail("frames: " + display.error);
      return 0;
    }

    // An app's session writes no files: one line on how its loop ran.
    void print_loop_line(const std::string &command, double rate, const HapticResult &h)
    {
      std::printf("modal-rt %s: %llu ticks at %g Hz (%.1f s), %llu overruns, %llu missed periods, %llu allocations "
                  "in the haptic thread\n",
                  command.c_str(), (unsigned long long)h.ticks, rate, h.wall_seconds, (unsigned long long)h.overruns,
                  (unsigned long long)h.missed_periods, (unsigned long long)h.allocations);
    }

    // The haptic thread's settings. A session with outputs records every tick (arrays sized here:
    // tick_limit 0 means the session is too long or empty); an app's session records nothing and
    // may run until Ctrl-C.
    HapticSettings haptic_settings(const RunOptions &o, double duration)
    {
      HapticSettings haptic;
      haptic.rate             = o.rate;
      haptic.record           = !o.app;
      const auto ticks        = std::uint64_t(std::llround(duration * o.rate));
      if (haptic.record)
        haptic.tick_limit = ticks <= max_ticks ? ticks : 0;
      else
        haptic.tick_limit = ticks > 0 ? ticks : UINT64_MAX; // until Ctrl-C
      haptic.impedance        = o.impedance;
      haptic.trace_decimation = std::uint32_t(std::max(1.0, std::round(o.rate / o.trace_rate)));
      haptic.spin_us          = o.spin_us;
      return haptic;
    }

    int execute(const RunOptions &o)
    {
      Session session;
      if (!load_session(o, session))
        return 1;
      const double         duration = o.duration > 0.0 ? o.duration : session.end_time;
      const HapticSettings haptic   = haptic_settings(o, duration);
      if (haptic.tick_limit == 0)
        return fail("the session is " + std::to_string(std::llround(duration * o.rate)) + " ticks long (" +
                    std::to_string(duration) + " s at " + std::to_string(o.rate) + " Hz): it must be 1 .. " +
                    std::to_string(max_ticks));
      if (!check_design_events(o, session))
        return 1;
      Live        live;
      std::string error;
      if (!open_live(o, session, live))
        return 1;
      if (!o.app && !prepare_output_dir(o.output_dir, error))
        return fail(error);
      if (!start_view(o, live, error))
        return fail(error);

      DisplaySettings display{o.output_dir, o.app ? o.app->display_rate : display_rate, o.frame_rate, !o.app};
      HapticResult    haptic_result;
      DisplayResult   display_result;
      install_stop_handler();
      run_threads(live.kernel, live.basis, *live.device, session, haptic, display, live.view.get(), haptic_result,
                  display_result, live.second.kernel ? &live.second : nullptr);
      live.device->close();
      if (!o.app)
        return write_results(o, session, duration, live, haptic_result, display_result);
      print_loop_line(o.command, o.rate, haptic_result);
      return 0;
    }
  } // namespace

  bool parse_friction(const std::string &text, double &static_friction, double &dynamic_friction, std::string &error)
  {
    const std::size_t at = text.find(',');
    char             *end_s = nullptr, *end_d = nullptr;
    const std::string mu_s = text.substr(0, at), mu_d = at == std::string::npos ? "" : text.substr(at + 1);
    const double      s = std::strtod(mu_s.c_str(), &end_s), d = std::strtod(mu_d.c_str(), &end_d);
    if (at == std::string::npos || mu_s.empty() || mu_d.empty() || *end_s != '\0' || *end_d != '\0' ||
        !std::isfinite(s) || !std::isfinite(d))
      error = "'" + text + "' is not MU_S,MU_D (two numbers)";
    else if (!(d >= 0.0 && d <= s && s <= 10.0))
      error = "'" + text + "': needs 0 <= MU_D <= MU_S <= 10";
    else
      static_friction = s, dynamic_friction = d;
    return error.empty();
  }

  std::string run_usage() { return usage_text(false); }
  std::string serve_usage() { return usage_text(true); }

  int run_command(int argc, char **argv, bool serve, WatchStarter watch)
  {
    RunOptions o;
    try
      {
        o = parse_options(argc, argv, serve);
      }
    catch (const UsageError &e)
      {
        std::fprintf(stderr, "modal-rt %s: %s\nusage:\n%s", serve ? "serve" : "run", e.message.c_str(),
                     usage_text(serve).c_str());
        return 2;
      }
    if (o.help)
      {
        std::printf("usage:\n%s", usage_text(serve).c_str());
        return 0;
      }
    o.watch   = watch;
    o.command = serve ? "serve" : "run";
    return execute(o);
  }

  int play_device_session(const DeviceSession &session, const std::string &command)
  {
    RunOptions o;
    o.app        = &session;
    o.command    = command;
    o.basis      = session.basis;
    o.rate       = session.rate;
    o.duration   = session.duration;
    o.impedance  = session.impedance;
    o.proxy            = session.proxy;
    o.static_friction  = session.static_friction;
    o.dynamic_friction = session.dynamic_friction;
    o.validity_level   = session.validity_level;
    o.validity_clamp   = session.validity_clamp;
    o.profile          = session.profile;
    o.frame_rate = 0.0;
    o.quiet      = true;
    return execute(o);
  }
} // namespace modalrt_tool
