// `modal-rt run`: a scripted session through the kernel in real time; `modal-rt serve`: the same
// loop with a device on the other end of a UDP socket (see realtime/README.md). An app that links
// the tools plays the same loop with a device of its own (the view's mouse, `modal-rt view`).
#pragma once

#include "devices.h"
#include "run_loop.h"

#include <modalrt/modalrt.h>
#include <mrt/command_line.h>

#include <functional>
#include <memory>
#include <string>

namespace modalrt_tool
{
  // What a live view is told of the session it watches, once the kernel exists (before the first tick).
  struct ViewContext
  {
    const modalrt_basis *basis;
    std::string          basis_path;
    modalrt_kernel      *kernel;
    std::uint32_t        hips;
    std::string          command; // "run", "serve", or the app's command that plays its own device
    bool                 proxy = false; // the kernel's contacts are sliding proxies (MODALRT_CONTACT_PROXY)
    std::uint32_t        validity_level = 5;     // [%] the kernel's validity_level (MODALRT_HIP_BEYOND_VALIDITY)
    bool                 validity_clamp = false; // the kernel's validity_clamp
  };

  // Why --view and `modal-rt view` are refused by a tool built without the view.
  inline constexpr const char *built_without_view =
    "this modal-rt was built without the view (it needs Boost.Beast from libboost-dev at configure time; "
    "see view/README.md)";

  // --view P on run and serve: starts a watch-only view on loopback port P (0: any free port).
  // Returns the observer of the run (destroyed before the kernel), or nullptr and a message.
  using WatchStarter = std::unique_ptr<RunObserver> (*)(const ViewContext &context, unsigned port,
                                                        std::string &error);

  // `modal-rt run` (serve false) or `modal-rt serve` (serve true: the UDP bridge, udp_device.h).
  // argv[0] is the first argument after the command; `watch` serves --view (null: the tool was
  // built without the view). Exit status: 0 done (end of session or Ctrl-C, or --help), 1 bad
  // basis/session file, device or output, 2 bad command line.
  int         run_command(int argc, char **argv, bool serve, WatchStarter watch);
  // The one line of `modal-rt --help` on run (serve false) or serve; COMMAND --help prints the table.
  std::string run_summary(bool serve);
  // "MU_S,MU_D" of --friction (serve, view): 0 <= MU_D <= MU_S <= 10; false and a message otherwise.
  bool        parse_friction(const std::string &text, double &static_friction, double &dynamic_friction,
                             std::string &error);

  // The options run, serve and an app's command (view) share, each declared once: --rate;
  // --contact and --friction; --validity-level and --validity-clamp.
  void add_rate_option(mrt::cli::OptionTable &table, double &rate);
  void add_contact_options(mrt::cli::OptionTable &table, bool &proxy, double &static_friction,
                           double &dynamic_friction);
  void add_validity_options(mrt::cli::OptionTable &table, std::uint32_t &level, bool &clamp);

  // A session an app plays with a device of its own: the run loop of `run` (the kernel defined for
  // that device and rate, the fail-safe defaults, the automatic snap distance), without a session
  // file and without outputs; the app's view watches it.
  struct DeviceSession
  {
    std::string basis;                 // FILE.mrt
    double      rate         = 1000.0; // [Hz] ticks
    double      duration     = 0.0;    // [s] of ticks; 0: until Ctrl-C
    bool        impedance    = false;  // false: admittance
    bool        proxy        = false;  // sliding proxy contacts (MODALRT_CONTACT_PROXY), with these coefficients
    double      static_friction  = modalrt_kernel_default_def().static_friction;
    double      dynamic_friction = modalrt_kernel_default_def().dynamic_friction;
    std::uint32_t validity_level = 5;  // [%] the kernel's validity_level, and its validity_clamp
    bool        validity_clamp   = false;
    double      display_rate = 60.0;   // [Hz] snapshots handed to the view
    std::string profile;               // a device profile (modalrt_device_profile_find; "": the kernel's default device)
    std::function<std::unique_ptr<Device>(const modalrt_basis *)>                          make_device;
    std::function<std::unique_ptr<RunObserver>(const ViewContext &, std::string &error)> start_view;
  };

  // Exit status: 0 done (duration or Ctrl-C), 1 bad basis, device or view.
  int play_device_session(const DeviceSession &session, const std::string &command);
} // namespace modalrt_tool
