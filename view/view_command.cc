// `modal-rt view`: the run loop (realtime/tools/run_loop.h) played by the browser's mouse
// (mouse_device.h, admittance), watched by the same live view as --view (run_view.h), which also
// takes the page's presses to the mouse.
#include "view_command.h"

#include "mouse_device.h"
#include "run_view.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
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
      bool          help       = false;
    };

    struct UsageError
    {
      std::string message;
    };

    double number(const std::string &option, const char *text, double low, double high)
    {
      char        *end   = nullptr;
      const double value = std::strtod(text, &end);
      if (end == text || *end != '\0' || !std::isfinite(value) || value < low || value > high)
        {
          char range[96];
          std::snprintf(range, sizeof range, "' is not a number in [%g, %g]", low, high);
          throw UsageError{option + ": '" + text + range};
        }
      return value;
    }

    Options parse(int argc, char **argv)
    {
      Options o;
      for (int i = 0; i < argc; ++i)
        {
          const std::string option = argv[i];
          if (option == "--help")
            {
              o.help = true;
              return o;
            }
          if (option == "--validity-clamp")
            {
              o.validity_clamp = true;
              continue;
            }
          if (option != "--basis" && option != "--port" && option != "--address" && option != "--rate" &&
              option != "--frame-rate" && option != "--duration" && option != "--contact" && option != "--friction" &&
              option != "--validity-level" && option != "--compare" && option != "--noise")
            throw UsageError{"unknown option '" + option + "'"};
          if (i + 1 >= argc)
            throw UsageError{option + " needs a value"};
          const char *value = argv[++i];
          if (option == "--basis")
            o.basis = value;
          else if (option == "--port")
            o.server.port = unsigned(number(option, value, 0, 65535));
          else if (option == "--address")
            o.server.address = value;
          else if (option == "--compare")
            o.server.compare_basis = value;
          else if (option == "--noise")
            {
              o.server.noise_percent = number(option, value, 0, 1e6);
              o.noise                = true;
            }
          else if (option == "--rate")
            o.rate = number(option, value, 100, 20000);
          else if (option == "--frame-rate")
            o.frame_rate = number(option, value, 1, 240);
          else if (option == "--contact")
            {
              if (std::string(value) != "snap" && std::string(value) != "proxy")
                throw UsageError{option + " '" + value + "' is not snap or proxy"};
              o.proxy = std::string(value) == "proxy";
            }
          else if (option == "--validity-level")
            {
              const std::string text = value;
              if (text != "1" && text != "5" && text != "10")
                throw UsageError{option + " '" + text + "' is not 1, 5 or 10 (percent)"};
              o.validity_level = std::uint32_t(std::stoul(text));
            }
          else if (option == "--friction")
            {
              std::string error;
              if (!modalrt_tool::parse_friction(value, o.static_friction, o.dynamic_friction, error))
                throw UsageError{option + " " + error};
            }
          else
            o.duration = number(option, value, 0, 1e7);
        }
      if (o.basis.empty())
        throw UsageError{"--basis FILE is required"};
      if (o.noise && o.server.compare_basis.empty())
        throw UsageError{"--noise is an option of --compare B.mrt"};
      return o;
    }
  } // namespace

  std::string view_usage()
  {
    return "       modal-rt view --basis FILE [--port P (8080; 0: any)] [--address A (127.0.0.1)] [--rate HZ (1000)]\n"
           "                     [--frame-rate HZ (60)] [--duration S (0: until Ctrl-C)] [--contact snap|proxy (snap)]\n"
           "                     [--friction MU_S,MU_D (0.3,0.2)] [--validity-level 1|5|10 (5)] [--validity-clamp]\n"
           "                     [--compare B.mrt [--noise PCT (1)]] [--help]\n"
           "         Prints the page's address with this run's secret token, http://ADDRESS:PORT/?token=HEX: open\n"
           "         that address. /ws and /api/* refuse a request without the token (401) or from another origin\n"
           "         or Host (403), on loopback and on --address alike; there is no way to turn the token off.\n"
           "         A client that is no browser passes it as ?token=HEX or the header X-Modal-RT-Token: HEX\n"
           "         (view/README.md, \"Access\"). The --view P of run and serve prints and checks the same.\n"
           "         --compare B.mrt: the Stiffness tab also shows where design B's felt-stiffness map differs\n"
           "         from this basis's, in % (modal-rt info --compare's numbers).\n";
  }

  int view_command(int argc, char **argv)
  {
    Options options;
    try
      {
        options = parse(argc, argv);
      }
    catch (const UsageError &e)
      {
        std::fprintf(stderr, "modal-rt view: %s\nusage:\n%s", e.message.c_str(), view_usage().c_str());
        return 2;
      }
    if (options.help)
      {
        std::printf("usage:\n%s", view_usage().c_str());
        return 0;
      }
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
    extensions.commands.push_back({"view", view_usage(), view_command});
    extensions.watch = start_watch_view;
    return extensions;
  }
} // namespace modalrt_view
