// `modal-rt view`: the run loop (realtime/tools/run_loop.h) played by the browser's mouse
// (mouse_device.h, admittance), watched by the same live view as --view (run_view.h), which also
// takes the page's presses to the mouse.
#include "view_command.h"

#include "mouse_device.h"
#include "run_view.h"

#include <mrt/command_line.h>

#include <cstdio>
#include <string>

namespace modalrt_view
{
  namespace
  {
    struct Options
    {
      std::string   basis;
      ServerOptions server;
      double        rate       = 1000.0; // [Hz]
      double        frame_rate = 60.0;   // [Hz] frames pushed to each browser
      double        duration   = 0.0;    // [s] 0: until SIGINT/SIGTERM
      bool          proxy      = false;  // --contact proxy: sliding contacts, the mouse drags them (impedance)
      double        static_friction  = modalrt_kernel_default_def().static_friction;
      double        dynamic_friction = modalrt_kernel_default_def().dynamic_friction;
      std::uint32_t validity_level   = 5;     // --validity-level: the kernel's (MODALRT_HIP_BEYOND_VALIDITY)
      bool          validity_clamp   = false; // --validity-clamp (impedance: --contact proxy)
      bool          noise            = false; // --noise given (an option of --compare)
      std::string   profile;                  // --device NAME: the device profile whose spec and scale the kernel renders
    };

    using mrt::cli::UsageError;

    const char *const summary = "The run loop played by the browser's mouse (admittance, or a sliding proxy "
                                "contact), with the live view of the deforming part (view/README.md).";

    const char *const notes =
      "Prints the page's address with this run's secret token, http://ADDRESS:PORT/?token=HEX: open\n"
      "that address. /ws and /api/* refuse a request without the token (401) or from another origin\n"
      "or Host (403), on loopback and on --address alike; there is no way to turn the token off.\n"
      "A client that is no browser passes it as ?token=HEX or the header X-Modal-RT-Token: HEX\n"
      "(view/README.md, \"Access\"). The --view P of run and serve prints and checks the same.\n"
      "--device PROFILE: the kernel renders that device's spec and haptic scale (realtime/README.md,\n"
      "\"What the hand feels\"): an impedance profile needs --contact proxy (the mouse drags a\n"
      "sliding contact, impedance), the admittance profile the default snap contact.\n";

    void add_server_options(mrt::cli::OptionTable &t, Options &o)
    {
      t.text("--basis", "FILE.mrt", "the basis file (.mrt)", [&o](const std::string &v) { o.basis = v; }).required();
      t.number("--port", "P", "the page's TCP port; 0: any free port", {0, 65535, "", true},
               [&o](double v) { o.server.port = unsigned(v); })
        .shown_default("8080");
      t.text("--address", "A", "the address the page is served on", [&o](const std::string &v) { o.server.address = v; })
        .shown_default("127.0.0.1");
      t.number("--frame-rate", "HZ", "frames pushed to each browser per second [Hz]", {1, 240, "Hz"},
               [&o](double v) { o.frame_rate = v; })
        .shown_default("60");
      t.number("--duration", "S", "how long to run [s]; 0: until Ctrl-C", {0, 1e7, "s"},
               [&o](double v) { o.duration = v; })
        .shown_default("0");
      t.text("--compare", "B.mrt", "the Stiffness tab also shows where design B's felt stiffness differs, in %",
             [&o](const std::string &v) { o.server.compare_basis = v; });
      t.number("--noise", "PCT", "--compare's noise floor [%]: a smaller relative difference is none", {0, 1e6, "%"},
               [&o](double v) {
                 o.server.noise_percent = v;
                 o.noise                = true;
               })
        .shown_default("1");
    }

    mrt::cli::OptionTable option_table(Options &o)
    {
      mrt::cli::OptionTable t("modal-rt view", summary);
      add_server_options(t, o);
      modalrt_tool::add_rate_option(t, o.rate);
      modalrt_tool::add_contact_options(t, o.proxy, o.static_friction, o.dynamic_friction);
      modalrt_tool::add_validity_options(t, o.validity_level, o.validity_clamp);
      t.text("--device", "PROFILE", "the device profile whose spec and haptic scale the kernel renders",
             [&o](const std::string &v) {
               modalrt_device_def spec;
               if (modalrt_device_profile_find(v.c_str(), &spec) != MODALRT_OK)
                 throw UsageError("--device '" + v + "' is not a device profile (touch, omni, desktop, falcon, "
                                  "omega.x, sigma.7, lambda.7, admittance)");
               o.profile = v;
             });
      t.notes(notes);
      return t;
    }
  } // namespace

  int view_command(int argc, char **argv)
  {
    Options                     options;
    const mrt::cli::OptionTable table = option_table(options);
    if (const int status = mrt::cli::parse_command_line(table, argc, argv); status >= 0)
      return status;
    if (options.noise && options.server.compare_basis.empty())
      return mrt::cli::report_usage_error(table, "--noise is an option of --compare B.mrt");
    MouseDevice                 *mouse = nullptr; // made by the loop once the basis is loaded
    modalrt_tool::DeviceSession session;
    session.basis        = options.basis;
    session.rate         = options.rate;
    session.duration     = options.duration;
    session.display_rate = options.frame_rate; // a frame per snapshot read
    session.impedance        = options.proxy; // a proxy slides on impedance ticks only
    session.proxy            = options.proxy;
    session.static_friction  = options.static_friction;
    session.dynamic_friction = options.dynamic_friction;
    session.validity_level   = options.validity_level;
    session.validity_clamp   = options.validity_clamp;
    session.profile          = options.profile;
    session.make_device  = [&mouse, &options](const modalrt_basis *basis) {
      auto device = std::make_unique<MouseDevice>(basis, options.proxy);
      mouse       = device.get();
      return device;
    };
    session.start_view = [&](const modalrt_tool::ViewContext &context, std::string &error) {
      return start_mouse_view(context, *mouse, options.server, error);
    };
    return modalrt_tool::play_device_session(session, "view");
  }

  modalrt_tool::ToolExtensions view_extensions()
  {
    modalrt_tool::ToolExtensions extensions;
    extensions.commands.push_back({"view", summary, view_command});
    extensions.watch = start_watch_view;
    return extensions;
  }
} // namespace modalrt_view
