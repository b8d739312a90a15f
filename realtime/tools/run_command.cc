#include "run_command.h"

#include "haptic_scale.h"

#include "devices.h"
#include "run_loop.h"
#include "run_outputs.h"
#include "session.h"
#include "stiffness_map.h"
#include "udp_device.h"

#include <modalrt/modalrt.h>
#include <mrt/command_line.h>

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

    using mrt::cli::OptionTable;
    using mrt::cli::UsageError;

    // A value that is one of two words: true for the first; otherwise a usage error naming both.
    bool first_of_two(const std::string &option, const std::string &value, const char *first, const char *second)
    {
      if (value != first && value != second)
        throw UsageError(option + " '" + value + "' is not " + first + " or " + second);
      return value == first;
    }

    void add_file_options(OptionTable &t, RunOptions &o)
    {
      t.text("--basis", "FILE.mrt", "the basis file (.mrt)", [&o](const std::string &v) { o.basis = v; }).required();
      if (!o.serve)
        t.text("--session", "SESSION.csv", "the scripted session: targets, forces, designs (realtime/README.md)",
               [&o](const std::string &v) { o.session = v; })
          .required();
      t.text("--output-dir", "DIR", "where trace.csv, presses.csv, slides.csv, frames/, stats.json and the plots go",
             [&o](const std::string &v) { o.output_dir = v; })
        .required();
    }

    // serve's UDP device (udp_device.h) and its contacts; run's come from the session's `proxy` row.
    void add_serve_options(OptionTable &t, RunOptions &o)
    {
      t.text("--bind", "ADDRESS", "the IPv4 address the UDP socket binds", [&o](const std::string &v) {
         in_addr address{};
         if (inet_pton(AF_INET, v.c_str(), &address) != 1)
           throw UsageError("--bind '" + v + "' is not an IPv4 address");
         o.udp.bind_address = v;
       }).shown_default("127.0.0.1");
      t.number("--port", "N", "the UDP port the device sends to", {1, 65535, "", true},
               [&o](double v) { o.udp.port = std::uint16_t(v); })
        .shown_default("47000");
      t.number("--hips", "N", "how many HIPs the device moves", {1, double(udp::max_hips), "", true},
               [&o](double v) { o.udp.hips = std::uint32_t(v); })
        .shown_default("1");
      t.number("--peer-timeout", "S", "silence after which the device counts as gone [s]", {1e-3, 3600, "s"},
               [&o](double v) { o.udp.peer_timeout = v; })
        .shown_default("1");
      t.text("--token", "HEX",
             "the device's secret, " + std::to_string(2 * udp::token_size) + " hexadecimal digits (default: random)",
             [&o](const std::string &v) {
               if (!udp::parse_token(v.c_str(), o.udp.token))
                 throw UsageError("--token is not " + std::to_string(2 * udp::token_size) + " hexadecimal digits");
               o.udp.token_given = true;
             });
      t.text("--token-file", "PATH", "where the token is written for the device to read",
             [&o](const std::string &v) { o.udp.token_file = v; })
        .shown_default("$XDG_RUNTIME_DIR/modal-rt/serve-PORT.token");
      add_contact_options(t, o.proxy, o.static_friction, o.dynamic_friction);
    }

    // The device, its rate and the kernel's fail-safe.
    void add_device_options(OptionTable &t, RunOptions &o)
    {
      add_rate_option(t, o.rate);
      t.number("--duration", "S", o.serve ? "how long to serve [s]" : "how long to run [s] (default: the session's end)",
               {1e-3, 1e6, "s"}, [&o](double v) { o.duration = v; })
        .shown_default(o.serve ? "600" : "");
      t.text("--mode", "impedance|admittance", "what the device sends: a position (impedance) or a force",
             [&o](const std::string &v) { o.impedance = first_of_two("--mode", v, "impedance", "admittance"); })
        .shown_default("impedance");
      if (!o.serve)
        t.text("--device", "hand|probe|PROFILE", "the simulated device: a hand, a rigid probe, or a hand on a profile",
               [&o](const std::string &v) {
                 modalrt_device_def spec;
                 if (modalrt_device_profile_find(v.c_str(), &spec) == MODALRT_OK)
                   {
                     o.device  = DeviceKind::hand;
                     o.profile = v;
                     return;
                   }
                 o.device = first_of_two("--device", v, "hand", "probe") ? DeviceKind::hand : DeviceKind::probe;
               })
          .shown_default("hand");
      t.text("--profile", "PROFILE",
             "the device profile the kernel renders: touch, omni, desktop, falcon, omega.x, sigma.7, lambda.7, admittance",
             [&o](const std::string &v) { o.profile = v; });
      t.number("--haptic-scale", "S", "the part's stiffness over the hand's (default: from the profile and the scene)",
               {1e-9, 1e3}, [&o](double v) { o.haptic_scale = v; });
      t.number("--hold", "S", "fail-safe: how long the last safe force is held without good input [s]", {0.0, 10.0, "s"},
               [&o](double v) { o.hold = v; })
        .shown_default("0.5");
      t.number("--ramp", "S", "fail-safe: then how long the force takes to ramp to zero [s]", {1e-6, 10.0, "s"},
               [&o](double v) { o.ramp = v; })
        .shown_default("0.05");
      t.number("--snap-distance", "M", "how far a HIP finds its vertex [m] (default: the longest display edge)",
               {1e-6, 1.0, "m"}, [&o](double v) { o.snap_distance = v; });
      t.number("--spin-us", "US", "busy wait before each tick's deadline [us]", {0.0, 1e6, "us"},
               [&o](double v) { o.spin_us = v; })
        .shown_default("100");
      add_validity_options(t, o.validity_level, o.validity_clamp);
    }

    // The second design, the files and the view.
    void add_output_options(OptionTable &t, RunOptions &o)
    {
      t.text("--design-b", "FILE.mrt", "a second design felt in turn (the session's `design` rows; serve: the flag)",
             [&o](const std::string &v) { o.design_b = v; });
      t.number("--fade", "S", "the crossfade from one design to the other [s]", {1e-3, 10.0, "s"},
               [&o](double v) { o.fade = v; })
        .shown_default("0.25");
      if (!o.serve)
        t.number("--blind", "SEED", "the trials in an order drawn from SEED; blind.csv logs the answers",
                 {0, 4294967295.0, "", true}, [&o](double v) {
                   o.blind      = true;
                   o.blind_seed = std::uint32_t(v);
                 });
      t.number("--frame-rate", "HZ", "frames/*.vtu per second of simulated time [Hz]; 0: none", {0.0, display_rate, "Hz"},
               [&o](double v) { o.frame_rate = v; })
        .shown_default(o.serve ? "0" : "10");
      t.number("--trace-rate", "HZ", "trace.csv rows per second of simulated time [Hz]", {1e-3, max_rate, "Hz"},
               [&o](double v) { o.trace_rate = v; })
        .shown_default("100");
      t.number("--view", "PORT", "the browser view, watch-only, on loopback port PORT (0: any free port)",
               {0, 65535, "", true}, [&o](double v) { o.view_port = int(v); });
      t.flag("--no-plot", "no force_displacement.png (it needs python3 and matplotlib)", [&o] { o.plot = false; });
      t.flag("--quiet", "no summary at the end", [&o] { o.quiet = true; });
    }

    const char *summary(bool serve)
    {
      return serve ? "The run loop for a device that talks UDP: it sends the HIPs' motion, the kernel sends back the "
                     "forces (realtime/README.md, udp_device.cc)."
                   : "A scripted session through the kernel in real time: the session's targets and forces, the "
                     "files of --output-dir (realtime/README.md).";
    }

    // Every option of `run` (o.serve false) or `serve`, writing into `o`. A new option is one row.
    OptionTable option_table(RunOptions &o)
    {
      OptionTable t(o.serve ? "modal-rt serve" : "modal-rt run", summary(o.serve));
      add_file_options(t, o);
      if (o.serve)
        add_serve_options(t, o);
      add_device_options(t, o);
      add_output_options(t, o);
      return t;
    }

    // The checks between options, after the table took them.
    void check_options(const RunOptions &o)
    {
      if (o.blind && o.design_b.empty())
        throw UsageError("--blind needs --design-b (the second design of the trials)");
      if (!o.design_b.empty() && o.view_port >= 0)
        throw UsageError("--view shows one design: it cannot be given with --design-b");
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
        throw UsageError("--device/--profile " + o.profile + ": " + error);
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
          fail(e.what());
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

  void add_rate_option(mrt::cli::OptionTable &t, double &rate)
  {
    t.number("--rate", "HZ", "the haptic loop's rate [Hz]", {min_rate, max_rate, "Hz"}, [&rate](double v) { rate = v; })
      .shown_default("1000");
  }

  void add_contact_options(mrt::cli::OptionTable &t, bool &proxy, double &static_friction, double &dynamic_friction)
  {
    t.text("--contact", "snap|proxy", "snap: a HIP takes the closest vertex; proxy: a sliding contact with friction",
           [&proxy](const std::string &v) { proxy = !first_of_two("--contact", v, "snap", "proxy"); })
      .shown_default("snap");
    t.text("--friction", "MU_S,MU_D", "the sliding contact's static and dynamic friction coefficients",
           [&static_friction, &dynamic_friction](const std::string &v) {
             std::string error;
             if (!parse_friction(v, static_friction, dynamic_friction, error))
               throw UsageError("--friction " + error);
           })
      .shown_default("0.3,0.2");
  }

  void add_validity_options(mrt::cli::OptionTable &t, std::uint32_t &level, bool &clamp)
  {
    t.text("--validity-level", "1|5|10", "the validity map's level [%] past which a contact is flagged",
           [&level](const std::string &v) {
             if (v != "1" && v != "5" && v != "10")
               throw UsageError("--validity-level '" + v + "' is not 1, 5 or 10 (percent)");
             level = std::uint32_t(std::stoul(v));
           })
      .shown_default("5");
    t.flag("--validity-clamp", "the rendered force held at the validity force", [&clamp] { clamp = true; });
  }

  std::string run_summary(bool serve) { return summary(serve); }

  int run_command(int argc, char **argv, bool serve, WatchStarter watch)
  {
    RunOptions o;
    o.serve      = serve;
    o.frame_rate = serve ? 0.0 : 10.0; // serve runs for minutes by default: no frames unless asked
    const OptionTable table = option_table(o);
    if (const int status = mrt::cli::parse_command_line(table, argc, argv); status >= 0)
      return status;
    try
      {
        check_options(o);
      }
    catch (const UsageError &e)
      {
        return mrt::cli::report_usage_error(table, e.what());
      }
    o.udp.rate = o.rate;
    o.watch    = watch;
    o.command  = serve ? "serve" : "run";
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
