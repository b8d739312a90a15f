// `modal-rt view`: a haptic loop driven by the browser's mouse, and the view server beside it.
//
// Threads: the haptic thread ticks the kernel (admittance, the mouse pushes with a force) at the
// tick rate and never waits: it reads the mouse through a wait-free triple buffer, publishes its
// outputs through another, and the kernel publishes the modal state through its own snapshot
// exchange. The server thread (view_server.cc) reads both at frame rate and talks to the browsers.
#include "view_command.h"

#include "frame_builder.h"
#include "triple_buffer.h"
#include "view_server.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace modalrt_view
{
  namespace
  {
    constexpr std::uint32_t mouse_hips = 2; // the second with a modifier key

    std::atomic<bool> stop_requested{false};
    extern "C" void   on_signal(int) { stop_requested = true; }

    // What the browser asks of the mouse HIPs (server thread -> haptic thread).
    struct MouseInput
    {
      std::uint32_t pressed[mouse_hips] = {0, 0};
      std::uint32_t vertex[mouse_hips]  = {0, 0};
      double        force[mouse_hips][3] = {};
    };

    // What the haptic thread publishes after each tick (haptic thread -> server thread).
    struct HapticState
    {
      HapticTick         tick;                  // statistics over the last full second
      modalrt_hip_output out[mouse_hips] = {};
    };

    struct Options
    {
      std::string   basis;
      ServerOptions server;
      double        rate     = 1000.0; // [Hz]
      double        duration = 0.0;    // [s] 0: until SIGINT/SIGTERM
    };

    // The mouse session: owns the kernel, the haptic thread, and builds the frames.
    class MouseSession : public FrameSource
    {
    public:
      MouseSession(const modalrt_basis *basis, const Options &options)
        : basis_(basis), options_(options), builder_(basis, mouse_hips)
      {
        modalrt_basis_get_info(basis, &info_);
        modalrt_kernel_def def = modalrt_kernel_default_def();
        def.time_step          = 1.0 / options.rate;
        def.hip_capacity       = mouse_hips;
        def.enable_profile     = 1;
        int status             = modalrt_kernel_create(basis, &def, &kernel_);
        if (status == MODALRT_OK)
          status = modalrt_snapshot_create(kernel_, &snapshot_);
        if (status != MODALRT_OK)
          throw std::runtime_error(std::string("view: kernel: ") + modalrt_last_error_message());
        vertices_ = modalrt_basis_display_vertices(basis);
        normals_  = modalrt_basis_display_normals(basis);
        // Idle HIPs wait outside the part, farther than the snap distance from it.
        for (int d = 0; d < 3; ++d)
          far_[d] = info_.bounds_max[d] + 0.25 + 10.0 * def.snap_distance;
        mouse_.publish(current_);
      }

      ~MouseSession() override
      {
        stop();
        modalrt_snapshot_destroy(snapshot_);
        modalrt_kernel_destroy(kernel_);
      }

      void start()
      {
        running_ = true;
        thread_  = std::thread([this] { haptic_loop(); });
      }
      void stop()
      {
        running_ = false;
        if (thread_.joinable())
          thread_.join();
      }

      // ------------------------------------------------------------------- server thread
      std::string command(const std::string &text) override
      {
        std::istringstream in(text);
        std::string        verb;
        unsigned long      hip = 0;
        in >> verb >> hip;
        if (!in || hip >= mouse_hips)
          return "error: '" + text + "': expected 'press HIP VERTEX FORCE' or 'release HIP' with HIP < 2";
        if (verb == "release")
          {
            current_.pressed[hip] = 0;
            mouse_.publish(current_);
            return "ok";
          }
        unsigned long vertex = 0;
        std::string   force_text;
        in >> vertex >> force_text;
        if (verb != "press" || !in || vertex >= info_.display_vertex_count)
          return "error: '" + text + "': expected 'press HIP VERTEX FORCE' with VERTEX < " +
                 std::to_string(info_.display_vertex_count);
        // The force magnitude [N] pushes along the inward normal. It is not range-checked here: a
        // non-finite or absurd force reaches the kernel, which rejects it as it would a device's.
        const double magnitude = std::strtod(force_text.c_str(), nullptr);
        current_.pressed[hip] = 1;
        current_.vertex[hip]  = std::uint32_t(vertex);
        for (int d = 0; d < 3; ++d)
          current_.force[hip][d] = -magnitude * normals_[3 * vertex + d];
        mouse_.publish(current_);
        return "ok";
      }

      bool frame(std::vector<unsigned char> &bytes) override
      {
        refresh();
        builder_.frame(bytes);
        return true;
      }

      std::string state_json() override
      {
        refresh();
        return builder_.state_json();
      }

      std::string session_json() override
      {
        return "{\"driver\":\"mouse\",\"watch_only\":false,\"hips\":" + std::to_string(mouse_hips) + "}";
      }

    private:
      // Server thread: the newest snapshot and haptic outputs.
      void refresh()
      {
        modalrt_kernel_snapshot_read(kernel_, snapshot_);
        haptic_read_.read(haptic_);
        builder_.update(snapshot_, haptic_.tick, haptic_.out);
      }

      // ------------------------------------------------------------------- haptic thread
      void haptic_loop()
      {
        modalrt_thread_enable_flush_to_zero();
        using clock = std::chrono::steady_clock;
        const auto period   = std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(1.0 / options_.rate));
        const auto spin     = std::chrono::microseconds(100);
        auto       deadline = clock::now();
        auto       window   = deadline;
        std::uint64_t window_ticks = 0;
        MouseInput         mouse;
        modalrt_hip_input  in[mouse_hips]  = {};
        modalrt_hip_output out[mouse_hips] = {};
        HapticState        state;
        TickHistogram     &durations = durations_, &lateness = lateness_;
        while (running_ && !stop_requested)
          {
            deadline += period;
            std::this_thread::sleep_until(deadline - spin);
            while (clock::now() < deadline)
              {
              }
            const auto start = clock::now();
            lateness.add(std::chrono::duration<double, std::micro>(start - deadline).count());
            mouse_.read(mouse);
            for (std::uint32_t h = 0; h < mouse_hips; ++h)
              {
                const std::uint32_t v = mouse.vertex[h];
                if (mouse.pressed[h] && (!out[h].in_contact || out[h].active_vertex != v))
                  modalrt_kernel_contact_begin(kernel_, h, v);
                else if (!mouse.pressed[h] && out[h].in_contact)
                  modalrt_kernel_release_hip(kernel_, h);
                for (int d = 0; d < 3; ++d)
                  {
                    in[h].position[d] = mouse.pressed[h] ? vertices_[3 * std::size_t(v) + d] : far_[d] + 0.05 * h;
                    in[h].velocity[d] = 0.0;
                    in[h].force[d]    = mouse.pressed[h] ? mouse.force[h][d] : 0.0;
                  }
              }
            modalrt_kernel_tick_admittance(kernel_, in, mouse_hips, out);
            const auto end = clock::now();
            durations.add(std::chrono::duration<double, std::micro>(end - start).count());
            ++window_ticks;
            if (end - window >= std::chrono::seconds(1))
              {
                close_window(state.tick.stats, durations, &lateness, window_ticks,
                             std::chrono::duration<double>(end - window).count());
                window       = end;
                window_ticks = 0;
              }
            stamp_tick(kernel_, state.tick);
            std::copy_n(out, mouse_hips, state.out);
            haptic_write_.publish(state);
          }
      }

      const modalrt_basis *basis_;
      Options              options_;
      modalrt_basis_info   info_{};
      modalrt_kernel      *kernel_   = nullptr;
      modalrt_snapshot    *snapshot_ = nullptr;
      const double        *vertices_ = nullptr, *normals_ = nullptr;
      double               far_[3]   = {};
      std::atomic<bool>    running_{false};
      std::thread          thread_;
      TickHistogram        durations_, lateness_; // haptic thread's

      TripleBuffer<MouseInput>  mouse_;
      MouseInput                current_; // server thread's
      TripleBuffer<HapticState> haptic_exchange_;
      TripleBuffer<HapticState> &haptic_write_ = haptic_exchange_, &haptic_read_ = haptic_exchange_;
      HapticState               haptic_;   // server thread's copy
      FrameBuilder              builder_;                // server thread's
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
          if (option != "--basis" && option != "--port" && option != "--address" && option != "--rate" &&
              option != "--frame-rate" && option != "--duration")
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
          else if (option == "--rate")
            o.rate = number(option, value, 100, 20000);
          else if (option == "--frame-rate")
            o.server.frame_rate = number(option, value, 1, 240);
          else
            o.duration = number(option, value, 0, 1e7);
        }
      if (o.basis.empty())
        throw UsageError{"--basis FILE is required"};
      return o;
    }
  } // namespace

  const char *view_usage()
  {
    return "       modal-rt view --basis FILE [--port P (8080; 0: any)] [--address A (127.0.0.1)] [--rate HZ (1000)]\n"
           "                     [--frame-rate HZ (60)] [--duration S (0: until Ctrl-C)]\n";
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
        std::fprintf(stderr, "modal-rt view: %s\nusage: %s", e.message.c_str(), view_usage());
        return 2;
      }
    modalrt_basis *basis = nullptr;
    if (modalrt_basis_load(options.basis.c_str(), &basis) != MODALRT_OK)
      {
        std::fprintf(stderr, "modal-rt view: %s\n", modalrt_last_error_message());
        return 1;
      }
    int status = 0;
    try
      {
        MouseSession session(basis, options);
        ViewServer   server(basis, options.basis, session, options.server);
        server.start();
        std::signal(SIGINT, on_signal);
        std::signal(SIGTERM, on_signal);
        session.start();
        std::printf("view: http://%s:%u/ (basis %s, %zu bytes sent once per browser; Ctrl-C stops)\n",
                    options.server.address.c_str(), server.port(), options.basis.c_str(), server.basis_bytes());
        std::fflush(stdout);
        const auto begin = std::chrono::steady_clock::now();
        while (!stop_requested &&
               (options.duration <= 0 ||
                std::chrono::steady_clock::now() - begin < std::chrono::duration<double>(options.duration)))
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
        session.stop();
        server.stop();
      }
    catch (const std::exception &e)
      {
        std::fprintf(stderr, "modal-rt view: %s\n", e.what());
        status = 1;
      }
    modalrt_basis_destroy(basis);
    return status;
  }
} // namespace modalrt_view
