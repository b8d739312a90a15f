// `modal-rt view`: a haptic loop driven by the browser's mouse, and the view server beside it.
//
// Threads: the haptic thread ticks the kernel (admittance, the mouse pushes with a force) at the
// tick rate and never waits: it reads the mouse through a wait-free triple buffer, publishes its
// outputs through another, and the kernel publishes the modal state through its own snapshot
// exchange. The server thread (view_server.cc) reads both at frame rate and talks to the browsers.
#include "view_command.h"

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

    // Tick durations and wake-up lateness over a window of ticks, in 0.1 us bins (no allocation).
    struct TickHistogram
    {
      static constexpr int bins = 5000; // up to 500 us; beyond, the last bin
      std::uint32_t        count[bins] = {};
      std::uint32_t        n           = 0;
      double               max_us      = 0.0;

      void add(double us)
      {
        const int b = std::min(bins - 1, std::max(0, int(us * 10.0)));
        ++count[b];
        ++n;
        max_us = std::max(max_us, us);
      }
      double percentile(double p) const
      {
        const std::uint64_t target = std::uint64_t(std::ceil(p * n));
        std::uint64_t       seen   = 0;
        for (int b = 0; b < bins; ++b)
          if ((seen += count[b]) >= target && target > 0)
            return (b + 0.5) / 10.0;
        return 0.0;
      }
      void clear() { *this = TickHistogram(); }
    };

    struct TickStats
    {
      double tick_p50_us = 0, tick_p99_us = 0, tick_max_us = 0; // kernel tick duration
      double late_p50_us = 0, late_p99_us = 0, late_max_us = 0; // tick start after its deadline
      double rate_hz     = 0;                                  // ticks per second of wall time
    };

    // What the haptic thread publishes after each tick (haptic thread -> server thread).
    struct HapticState
    {
      std::uint64_t      tick    = 0;
      double             wall_ms = 0.0; // [ms] epoch, end of the tick
      double             time    = 0.0; // [s] simulated
      std::uint64_t      rejected = 0;
      modalrt_hip_output out[mouse_hips] = {};
      TickStats          stats;        // over the last full second
    };

    struct Options
    {
      std::string   basis;
      ServerOptions server;
      double        rate     = 1000.0; // [Hz]
      double        duration = 0.0;    // [s] 0: until SIGINT/SIGTERM
      bool          quiet    = false;
    };

    // The mouse session: owns the kernel, the haptic thread, and builds the frames.
    class MouseSession : public FrameSource
    {
    public:
      MouseSession(const modalrt_basis *basis, const Options &options) : basis_(basis), options_(options)
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
        modalrt_snapshot_info si{};
        modalrt_snapshot_get_info(snapshot_, &si);
        const auto put = [&bytes](const void *p, std::size_t n) {
          const auto *c = static_cast<const unsigned char *>(p);
          bytes.insert(bytes.end(), c, c + n);
        };
        const auto u32 = [&](std::uint32_t v) { put(&v, 4); };
        const auto f64 = [&](double v) { put(&v, 8); };
        u32(0x4654524Du); // "MRTF"
        u32(1);
        f64(haptic_.wall_ms);
        f64(wall_clock_ms());
        f64(double(si.tick));
        f64(si.time);
        u32(si.space);
        u32(si.mode_count);
        u32(mouse_hips);
        u32(contact_count_);
        const TickStats &t = haptic_.stats;
        for (double v : {double(haptic_.tick), double(haptic_.rejected), t.tick_p50_us, t.tick_p99_us, t.tick_max_us,
                         t.late_p99_us, t.late_max_us, t.rate_hz})
          f64(v);
        put(modalrt_snapshot_modal_coordinates(snapshot_), 8 * std::size_t(si.mode_count));
        for (std::uint32_t k = 0; k < contact_count_; ++k)
          {
            u32(contact_vertices_[k]);
            u32(0);
            put(&contact_corrections_[3 * k], 24);
          }
        for (std::uint32_t h = 0; h < mouse_hips; ++h)
          {
            const Hip &hip = hips_[h];
            u32(hip.in_contact);
            u32(hip.vertex);
            u32(hip.full_fe);
            u32(0);
            put(hip.force, 24);
            put(hip.displacement, 24);
            put(hip.felt, 24);
            f64(hip.static_stiffness);
          }
        return true;
      }

      std::string state_json() override
      {
        refresh();
        modalrt_snapshot_info si{};
        modalrt_snapshot_get_info(snapshot_, &si);
        const TickStats   &t = haptic_.stats;
        std::ostringstream j;
        j.precision(17);
        j << "{\"tick\":" << si.tick << ",\"haptic_tick\":" << haptic_.tick << ",\"time\":" << si.time
          << ",\"space\":" << si.space << ",\"rejected_ticks\":" << haptic_.rejected << ",\"tick_us\":{\"p50\":"
          << t.tick_p50_us << ",\"p99\":" << t.tick_p99_us << ",\"max\":" << t.tick_max_us
          << "},\"lateness_us\":{\"p50\":" << t.late_p50_us << ",\"p99\":" << t.late_p99_us << ",\"max\":"
          << t.late_max_us << "},\"tick_rate_hz\":" << t.rate_hz << ",\"hips\":[";
        for (std::uint32_t h = 0; h < mouse_hips; ++h)
          {
            const Hip &hip = hips_[h];
            j << (h ? "," : "") << "{\"in_contact\":" << hip.in_contact << ",\"vertex\":"
              << (hip.in_contact ? double(hip.vertex) : -1.0) << ",\"full_fe\":" << hip.full_fe << ",\"force\":["
              << hip.force[0] << "," << hip.force[1] << "," << hip.force[2] << "],\"displacement\":["
              << hip.displacement[0] << "," << hip.displacement[1] << "," << hip.displacement[2] << "],\"felt\":["
              << hip.felt[0] << "," << hip.felt[1] << "," << hip.felt[2] << "],\"static_stiffness_n_per_m\":"
              << (std::isfinite(hip.static_stiffness) ? hip.static_stiffness : -1.0) << "}";
          }
        j << "]}";
        return j.str();
      }

    private:
      struct Hip
      {
        std::uint32_t in_contact = 0, vertex = MODALRT_NONE, full_fe = 0, space = MODALRT_NONE;
        double        force[3] = {}, displacement[3] = {}, felt[3] = {};
        double        static_stiffness = 0.0; // [N/m] 1 / (n^T G n) along the force
      };

      // Server thread: the newest snapshot and haptic outputs, and what the page needs of them.
      void refresh()
      {
        modalrt_kernel_snapshot_read(kernel_, snapshot_);
        haptic_read_.read(haptic_);
        modalrt_snapshot_get_contacts(snapshot_, mouse_hips, contact_vertices_, contact_corrections_, &contact_count_);
        modalrt_snapshot_info si{};
        modalrt_snapshot_get_info(snapshot_, &si);
        for (std::uint32_t h = 0; h < mouse_hips; ++h)
          {
            const modalrt_hip_output &o   = haptic_.out[h];
            Hip                      &hip = hips_[h];
            const std::uint32_t       v   = o.in_contact ? o.active_vertex : MODALRT_NONE;
            std::copy_n(o.force, 3, hip.force);
            hip.in_contact = o.in_contact;
            if (v == MODALRT_NONE)
              {
                hip.vertex = MODALRT_NONE;
                std::fill_n(hip.displacement, 3, 0.0);
                std::fill_n(hip.felt, 3, 0.0);
                continue;
              }
            // The kernel's own reconstruction of the active vertex from the same snapshot.
            modalrt_display_reconstruct_f64(snapshot_, v, v + 1, MODALRT_DISPLAY_DISPLACEMENTS, hip.displacement);
            for (int d = 0; d < 3; ++d)
              hip.felt[d] = o.position[d] - vertices_[3 * std::size_t(v) + d];
            if (v != hip.vertex || si.space != hip.space)
              {
                double G[9];
                hip.static_stiffness = 0.0;
                hip.full_fe          = 0;
                if (modalrt_basis_contact_compliance(basis_, si.space, v, G, &hip.full_fe) == MODALRT_OK)
                  {
                    const double *n   = &normals_[3 * std::size_t(v)];
                    double        nGn = 0.0;
                    for (int a = 0; a < 3; ++a)
                      for (int b = 0; b < 3; ++b)
                        nGn += n[a] * G[3 * a + b] * n[b];
                    hip.static_stiffness = nGn > 0.0 ? 1.0 / nGn : 0.0;
                  }
                hip.vertex = v;
                hip.space  = si.space;
              }
          }
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
                const double seconds    = std::chrono::duration<double>(end - window).count();
                state.stats.tick_p50_us = durations.percentile(0.5);
                state.stats.tick_p99_us = durations.percentile(0.99);
                state.stats.tick_max_us = durations.max_us;
                state.stats.late_p50_us = lateness.percentile(0.5);
                state.stats.late_p99_us = lateness.percentile(0.99);
                state.stats.late_max_us = lateness.max_us;
                state.stats.rate_hz     = window_ticks / seconds;
                durations.clear();
                lateness.clear();
                window       = end;
                window_ticks = 0;
              }
            modalrt_kernel_stats ks{};
            modalrt_kernel_get_stats(kernel_, &ks);
            state.tick     = ks.tick_count;
            state.time     = ks.time;
            state.rejected = ks.rejected_ticks;
            state.wall_ms  = wall_clock_ms();
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
      Hip                       hips_[mouse_hips];
      std::uint32_t             contact_vertices_[mouse_hips] = {};
      double                    contact_corrections_[3 * mouse_hips] = {};
      std::uint32_t             contact_count_ = 0;
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
        throw UsageError{option + ": '" + text + "' is not a number in [" + std::to_string(low) + ", " +
                         std::to_string(high) + "]"};
      return value;
    }

    Options parse(int argc, char **argv)
    {
      Options o;
      for (int i = 0; i < argc; ++i)
        {
          const std::string option = argv[i];
          if (option == "--quiet")
            {
              o.quiet = true;
              continue;
            }
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
          else if (option == "--duration")
            o.duration = number(option, value, 0, 1e7);
          else
            throw UsageError{"unknown option '" + option + "'"};
        }
      if (o.basis.empty())
        throw UsageError{"--basis FILE is required"};
      return o;
    }
  } // namespace

  const char *view_usage()
  {
    return "       modal-rt view --basis FILE [--port P (8080; 0: any)] [--address A (127.0.0.1)] [--rate HZ (1000)]\n"
           "                     [--frame-rate HZ (60)] [--duration S (0: until Ctrl-C)] [--quiet]\n";
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
