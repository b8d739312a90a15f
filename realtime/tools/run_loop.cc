#include "run_loop.h"

#include "allocation_counter.h"
#include "run_outputs.h"
#include "stiffness_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <csignal>
#include <memory>
#include <thread>

#include <pthread.h>
#include <sched.h>

namespace modalrt_tool
{
  namespace
  {
    using Clock = std::chrono::steady_clock;

    std::atomic<bool> stop_flag{false};
    static_assert(std::atomic<bool>::is_always_lock_free, "the stop flag is set from a signal handler");

    extern "C" void on_stop_signal(int) { stop_flag.store(true, std::memory_order_relaxed); }

    void wait_until(Clock::time_point deadline, std::chrono::nanoseconds margin)
    {
      if (deadline - Clock::now() > margin)
        std::this_thread::sleep_until(deadline - margin);
      while (Clock::now() < deadline)
        {
        }
    }

    // SCHED_FIFO for the haptic thread when the system allows it (root or CAP_SYS_NICE/rtprio
    // limits); otherwise the thread keeps the default policy and stats.json says so.
    bool try_realtime_priority()
    {
      sched_param param{};
      param.sched_priority = std::min(80, sched_get_priority_max(SCHED_FIFO));
      return pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
    }

    bool finite_output(const modalrt_hip_output &o)
    {
      for (int d = 0; d < 3; ++d)
        if (!std::isfinite(o.position[d]) || !std::isfinite(o.velocity[d]) || !std::isfinite(o.force[d]))
          return false;
      return true;
    }

    // Slides recorded per HIP (a session's slides are a handful; a device's through serve may be many:
    // those past this are counted, not recorded).
    constexpr std::size_t slide_capacity = 4096;

    // Everything the haptic thread touches, sized before the first tick.
    class HapticLoop
    {
    public:
      HapticLoop(modalrt_kernel *kernel, const modalrt_basis *basis, Device &device, const Session &session,
                 const HapticSettings &settings, RunObserver *observer, HapticResult &result,
                 const SecondDesign *second, std::atomic<std::uint32_t> &front_design)
        : kernel_(kernel), device_(device), session_(session), settings_(settings), observer_(observer),
          result_(result), hips_(device.hip_count()), inputs_(hips_), outputs_(hips_),
          second_(second ? *second : SecondDesign{}), bases_{basis, second_.basis}, front_design_(front_design),
          blend_(second_.fade * settings.rate, modalrt_kernel_default_def().force_rate_limit)
      {
        result_.beyond_validity_ticks.assign(hips_, 0);
        if (second_.kernel)
          {
            outputs_a_.resize(hips_);
            outputs_b_.resize(hips_);
          }
        if (second_.blind)
          blind_ = BlindTrials(count_design_events(session).trial, second_.seed);
        if (!settings.record)
          return;
        result_.latency_us.assign(settings.tick_limit, 0.0f);
        result_.period_us.assign(settings.tick_limit, 0.0f);
        const std::uint64_t rows = settings.tick_limit / settings.trace_decimation + 1;
        result_.trace.assign(rows * hips_, TraceSample{});
        slides_.reset(hips_, slide_capacity * hips_, settings.impedance);
      }

      void run(std::atomic<bool> &done)
      {
        result_.realtime_priority = try_realtime_priority();
        modalrt_thread_enable_flush_to_zero();
        const std::chrono::nanoseconds period{std::llround(1e9 / settings_.rate)};
        // Sleeping is only precise to tens of microseconds on a general-purpose kernel: sleep until
        // spin_us before the deadline, then spin on the clock. At most half a period: a SCHED_FIFO
        // thread that never sleeps is throttled by the kernel (sched_rt_runtime_us), tens of ms at once.
        const std::chrono::nanoseconds margin =
          std::min(std::chrono::nanoseconds(std::llround(1e3 * settings_.spin_us)), period / 2);
        const double                   T      = 1.0 / settings_.rate;

        count_allocations_in_this_thread(true);
        const Clock::time_point start    = Clock::now();
        Clock::time_point       deadline = start, previous = start;
        std::uint64_t           n        = 0;
        for (; n < settings_.tick_limit && !stop_flag.load(std::memory_order_relaxed); ++n)
          {
            wait_until(deadline, margin);
            const Clock::time_point begin = Clock::now();
            tick(n, n * T);
            const Clock::time_point end = Clock::now();
            if (settings_.record)
              {
                result_.latency_us[n] = float(std::chrono::duration<double, std::micro>(end - begin).count());
                result_.period_us[n]  = n == 0 ? float(1e6 * T)
                                               : float(std::chrono::duration<double, std::micro>(begin - previous).count());
              }
            if (observer_)
              observer_->ticked(TickTiming{deadline, begin, end}, outputs_.data(), hips_);
            previous = begin;
            deadline += period;
            if (end > deadline)
              {
                ++result_.overruns;
                if (end - deadline > period)
                  {
                    result_.missed_periods += std::uint64_t((end - deadline) / period);
                    deadline = end; // restart the schedule: no burst of catch-up ticks
                  }
              }
          }
        count_allocations_in_this_thread(false);
        finish(n, start);
        done.store(true);
      }

    private:
      // After the last tick: the counters, and the arrays cut to the ticks that ran.
      void finish(std::uint64_t n, Clock::time_point start)
      {
        result_.allocations  = counted_allocations();
        result_.ticks        = n;
        result_.interrupted  = n < settings_.tick_limit;
        result_.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
        if (settings_.record)
          {
            result_.latency_us.resize(n);
            result_.period_us.resize(n);
            const std::uint64_t rows = (n + settings_.trace_decimation - 1) / settings_.trace_decimation;
            result_.trace.resize(rows * hips_); // rows past a stopped session's last tick were never written
          }
        if (settings_.record)
          {
            result_.slides         = slides_.finish();
            result_.slides_dropped = slides_.dropped();
            result_.creeps         = slides_.creeps();
          }
        result_.last_inputs  = inputs_;
        result_.last_outputs = outputs_;
        result_.trials       = blind_.trials();
      }

      void tick(std::uint64_t n, double t)
      {
        apply_events(t);
        apply_frame(t);
        const bool fresh       = device_.read_state(t, inputs_.data());
        const bool new_session = device_.take_session_change(); // no contact carries over to a new device session
        if (fresh)
          {
            apply_contact_requests();
            follow_device_design();
          }
        if (!second_.kernel)
          tick_kernel(kernel_, fresh, new_session, outputs_.data());
        else
          {
            tick_kernel(kernel_, fresh, new_session, outputs_a_.data());
            tick_kernel(second_.kernel, fresh, new_session, outputs_b_.data());
            blend_.blend(outputs_a_.data(), outputs_b_.data(), hips_, outputs_.data());
            front_design_.store(blend_.front(), std::memory_order_relaxed);
            observe_blind();
          }
        for (std::uint32_t h = 0; h < hips_; ++h)
          {
            const modalrt_hip_output &o = outputs_[h];
            if (settings_.impedance)
              device_.write_force(h, o.force);
            else
              device_.track_position(h, o.position, o.velocity, o.in_contact != 0);
            device_.report_output(h, o);
            if (!finite_output(o))
              ++result_.non_finite_outputs;
            if (o.flags & MODALRT_HIP_BEYOND_VALIDITY)
              ++result_.beyond_validity_ticks[h];
          }
        device_.end_tick();
        if (!settings_.record)
          return;
        slides_.observe(t, inputs_.data(), outputs_.data(), frame_position_, bases_[blend_.front()]);
        if (n % settings_.trace_decimation == 0)
          record_trace(n / settings_.trace_decimation, t);
      }

      void tick_kernel(modalrt_kernel *kernel, bool fresh, bool new_session, modalrt_hip_output *outputs)
      {
        if (new_session)
          modalrt_kernel_begin_session(kernel);
        if (!fresh)
          modalrt_kernel_tick_missing(kernel, hips_, outputs); // the fail-safe rule
        else if (settings_.impedance)
          modalrt_kernel_tick_impedance(kernel, inputs_.data(), hips_, outputs);
        else
          modalrt_kernel_tick_admittance(kernel, inputs_.data(), hips_, outputs);
      }

      // A device that chooses the design itself (serve's state_design_b flag).
      void follow_device_design()
      {
        const int design = device_.requested_design();
        if (!second_.kernel || design < 0 || std::uint32_t(design) == blend_.shown())
          return;
        blend_.show(std::uint32_t(design));
        ++result_.design_switches;
      }

      // The blind mode's truth: the map value at the first HIP's contact while one design is felt alone.
      void observe_blind()
      {
        if (!blind_.active() || blend_.fading())
          return;
        const std::uint32_t design = blend_.front();
        for (std::uint32_t h = 0; h < hips_; ++h)
          if (outputs_[h].in_contact && outputs_[h].active_vertex != MODALRT_NONE)
            {
              blind_.observe(scene_felt_stiffness(bases_[design], outputs_[h].active_vertex));
              return;
            }
      }

      // A device that picks its contacts itself (the view's mouse clicks a vertex).
      void apply_contact_requests()
      {
        for (std::uint32_t h = 0; h < hips_; ++h)
          {
            const ContactRequest request = device_.contact_request(h);
            if (request.kind == ContactRequest::none)
              continue;
            const int status = request.kind == ContactRequest::press
                                 ? modalrt_kernel_contact_begin(kernel_, h, request.vertex)
                                 : modalrt_kernel_release_hip(kernel_, h);
            ++result_.events_applied;
            if (status != MODALRT_OK)
              ++result_.failed_events;
          }
      }

      // Session events due at or before t (each applied once, in file order).
      void apply_events(double t)
      {
        const std::vector<Event> &events = session_.events;
        for (; next_event_ < events.size() && events[next_event_].time <= t; ++next_event_)
          {
            const Event &e = events[next_event_];
            ++result_.events_applied;
            if (e.kind == EventKind::press || e.kind == EventKind::release)
              apply_contact_event(e);
            else
              apply_design_event(e, t);
          }
      }

      void apply_contact_event(const Event &e)
      {
        const bool press  = e.kind == EventKind::press;
        int        status = press ? modalrt_kernel_contact_begin(kernel_, e.hip, e.vertex)
                                  : modalrt_kernel_release_hip(kernel_, e.hip);
        if (second_.kernel && status == MODALRT_OK)
          status = press ? modalrt_kernel_contact_begin(second_.kernel, e.hip, e.vertex_b)
                         : modalrt_kernel_release_hip(second_.kernel, e.hip);
        if (status != MODALRT_OK)
          ++result_.failed_events;
      }

      // design, trial, present, answer: which design the hand feels (run_command checks before the
      // first tick that they come with a second design, and the blind ones with the blind mode).
      void apply_design_event(const Event &e, double t)
      {
        switch (e.kind)
          {
            case EventKind::design:
              blend_.show(e.choice);
              ++result_.design_switches;
              break;
            case EventKind::trial:
              blind_.begin(t);
              break;
            case EventKind::present:
              blind_.shown(e.choice);
              blend_.show(blind_.design_of(e.choice));
              ++result_.design_switches;
              break;
            case EventKind::answer:
              blind_.answer(e.choice, t);
              break;
            default:
              break;
          }
      }

      // The part's frame follows the session's frame keys (translation only).
      void apply_frame(double t)
      {
        if (session_.frame.empty())
          return;
        ChannelSample s;
        sample(session_.frame, t, frame_cursor_, s);
        modalrt_frame_state f = modalrt_frame_state_identity();
        for (int d = 0; d < 3; ++d)
          {
            f.position[d]            = s.value[d];
            f.linear_velocity[d]     = s.velocity[d];
            f.linear_acceleration[d] = s.acceleration[d];
          }
        if (modalrt_kernel_set_frame(kernel_, &f) == MODALRT_OK) // a rejected frame is counted by the kernel
          std::copy_n(f.position, 3, frame_position_);
      }

      void record_trace(std::uint64_t row, double t)
      {
        for (std::uint32_t h = 0; h < hips_; ++h)
          {
            TraceSample              &s = result_.trace[row * hips_ + h];
            const modalrt_hip_output &o = outputs_[h];
            s.time                      = t;
            std::copy_n(inputs_[h].position, 3, s.hip);
            std::copy_n(o.position, 3, s.contact);
            std::copy_n(o.force, 3, s.force);
            std::copy_n(frame_position_, 3, s.frame);
            s.in_contact    = o.in_contact;
            s.active_vertex = o.active_vertex;
            s.space         = o.space;
            s.flags         = o.flags;
            s.proxy_triangle = o.proxy_triangle;
            std::copy_n(o.proxy_weights, 3, s.proxy_weights);
            s.design       = blend_.front();
            s.design_share = float(blend_.share_b());
          }
      }

      modalrt_kernel                 *kernel_;
      Device                         &device_;
      const Session                  &session_;
      const HapticSettings           &settings_;
      RunObserver                    *observer_;
      HapticResult                   &result_;
      const std::uint32_t             hips_;
      std::vector<modalrt_hip_input>  inputs_;
      std::vector<modalrt_hip_output> outputs_;
      std::size_t                     next_event_   = 0;
      std::size_t                     frame_cursor_ = 0;
      double                          frame_position_[3] = {0.0, 0.0, 0.0}; // [m] of the last accepted frame
      SlideTracker                    slides_;
      const SecondDesign              second_;
      const modalrt_basis            *bases_[2];
      std::atomic<std::uint32_t>     &front_design_; // read by the display thread
      DesignBlend                     blend_;
      BlindTrials                     blind_;
      std::vector<modalrt_hip_output> outputs_a_, outputs_b_; // two designs: each kernel's own
    };

    // What the display thread reads of one design: its kernel's snapshot and its surface's frames.
    struct DesignDisplay
    {
      DesignDisplay(modalrt_kernel *design_kernel, const modalrt_basis *basis) : kernel(design_kernel), writer(basis)
      {
        modalrt_basis_info info;
        modalrt_basis_get_info(basis, &info);
        vertex_count = info.display_vertex_count;
        displacements.assign(3 * std::size_t(vertex_count), 0.0f);
        if (modalrt_snapshot_create(kernel, &snapshot) != MODALRT_OK)
          snapshot = nullptr;
      }
      ~DesignDisplay() { modalrt_snapshot_destroy(snapshot); }
      DesignDisplay(const DesignDisplay &) = delete;
      DesignDisplay &operator=(const DesignDisplay &) = delete;

      modalrt_kernel    *kernel;
      VtuFrameWriter     writer;
      modalrt_snapshot  *snapshot = nullptr;
      std::vector<float> displacements;
      std::uint32_t      vertex_count = 0;
    };

    // The display side: snapshots at 60 Hz, a VTU frame every 1/frame_rate s of simulated time, of
    // the design in front (two designs: the one the hand mostly feels).
    class DisplayLoop
    {
    public:
      DisplayLoop(modalrt_kernel *kernel, const modalrt_basis *basis, const SecondDesign *second,
                  const DisplaySettings &settings, RunObserver *observer, DisplayResult &result,
                  const std::atomic<std::uint32_t> &front_design)
        : settings_(settings), observer_(observer), result_(result), front_design_(front_design)
      {
        designs_.emplace_back(new DesignDisplay(kernel, basis));
        if (second && second->kernel)
          designs_.emplace_back(new DesignDisplay(second->kernel, second->basis));
        for (const auto &design : designs_)
          if (!design->snapshot)
            result_.error = std::string("cannot create a display snapshot: ") + modalrt_last_error_message();
      }

      void run(const std::atomic<bool> &haptic_done)
      {
        if (!result_.error.empty())
          return;
        const auto period   = std::chrono::nanoseconds(std::llround(1e9 / settings_.rate));
        auto       deadline = Clock::now();
        while (!haptic_done.load())
          {
            deadline += period;
            std::this_thread::sleep_until(deadline);
            if (Clock::now() - deadline > period)
              deadline = Clock::now(); // writing a frame took long: no burst of redraws
            redraw(false);
          }
        redraw(true); // the final state is always in the frames
      }

    private:
      void redraw(bool last)
      {
        DesignDisplay &d     = *designs_[std::min<std::size_t>(front_design_.load(), designs_.size() - 1)];
        const bool     fresh = modalrt_kernel_snapshot_read(d.kernel, d.snapshot) == 1;
        if (fresh && observer_ && &d == designs_.front().get())
          observer_->displayed(d.snapshot);
        if ((!fresh && !last) || !settings_.reconstruct)
          return;
        const Clock::time_point begin = Clock::now();
        modalrt_display_reconstruct(d.snapshot, 0, d.vertex_count, MODALRT_DISPLAY_DISPLACEMENTS, d.displacements.data());
        ++result_.reconstructions;
        result_.max_reconstruct_ms =
          std::max(result_.max_reconstruct_ms, std::chrono::duration<double, std::milli>(Clock::now() - begin).count());
        modalrt_snapshot_info info;
        modalrt_snapshot_get_info(d.snapshot, &info);
        const bool due = settings_.frame_rate > 0.0 && (info.time >= next_frame_time_ || last);
        if (!due || !result_.error.empty() || (last && !result_.frames.empty() && result_.frames.back().time == info.time))
          return;
        char name[64];
        std::snprintf(name, sizeof name, "frames/frame_%06zu.vtu", result_.frames.size());
        std::string error;
        if (!d.writer.write(settings_.output_dir + "/" + name, info, d.displacements.data(), error))
          {
            result_.error = error;
            return;
          }
        result_.frames.push_back(FrameRecord{info.time, name});
        next_frame_time_ = info.time + 1.0 / settings_.frame_rate;
      }

      const DisplaySettings                      &settings_;
      RunObserver                                *observer_;
      DisplayResult                              &result_;
      const std::atomic<std::uint32_t>           &front_design_;
      std::vector<std::unique_ptr<DesignDisplay>> designs_;
      double                                      next_frame_time_ = 0.0;
    };
  } // namespace

  void install_stop_handler()
  {
    struct sigaction action
    {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND; // a second Ctrl-C stops the program the default way
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
  }

  bool stop_requested() { return stop_flag.load(); }

  void run_threads(modalrt_kernel *kernel, const modalrt_basis *basis, Device &device, const Session &session,
                   const HapticSettings &haptic, const DisplaySettings &display, RunObserver *observer,
                   HapticResult &haptic_result, DisplayResult &display_result, const SecondDesign *second)
  {
    std::atomic<std::uint32_t> front_design{0};
    HapticLoop  haptic_loop(kernel, basis, device, session, haptic, observer, haptic_result, second, front_design);
    DisplayLoop display_loop(kernel, basis, second, display, observer, display_result, front_design);
    std::atomic<bool> haptic_done{false};
    std::thread       display_thread([&] { display_loop.run(haptic_done); });
    std::thread       haptic_thread([&] { haptic_loop.run(haptic_done); });
    haptic_thread.join();
    display_thread.join();
  }
} // namespace modalrt_tool
