#include "run_view.h"

#include "frame_builder.h"
#include "page_command.h"
#include "triple_buffer.h"
#include "view_json.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace modalrt_view
{
  namespace
  {
    using modalrt_tool::TickTiming;
    using modalrt_tool::ViewContext;

    // What the haptic thread publishes after each tick.
    struct TickOutputs
    {
      HapticTick         tick;
      modalrt_hip_output out[run_view_max_hips] = {};
    };

    // The haptic side of the view: each tick's outputs and timing, published wait-free. Tick
    // duration is wake-up to device written, lateness is wake-up after the deadline, both over the
    // last full second of wall time.
    class TickPublisher
    {
    public:
      explicit TickPublisher(modalrt_kernel *kernel) : kernel_(kernel) {}

      // Haptic thread: no allocation, no lock.
      void ticked(const TickTiming &timing, const modalrt_hip_output *outputs, std::uint32_t hips)
      {
        using us = std::chrono::duration<double, std::micro>;
        durations_.add(us(timing.end - timing.begin).count());
        lateness_.add(us(timing.begin - timing.deadline).count());
        if (window_ticks_++ == 0)
          window_ = timing.begin;
        if (timing.end - window_ >= std::chrono::seconds(1))
          {
            close_window(state_.tick.stats, durations_, &lateness_, window_ticks_,
                         std::chrono::duration<double>(timing.end - window_).count());
            window_ticks_ = 0;
          }
        stamp_tick(kernel_, state_.tick);
        std::copy_n(outputs, hips, state_.out);
        exchange_.publish(state_);
      }

      // Display thread: the newest tick's outputs.
      void read(TickOutputs &outputs) { exchange_.read(outputs); }

    private:
      modalrt_kernel                       *kernel_;
      TickOutputs                           state_; // haptic thread's
      TickHistogram                         durations_, lateness_;
      std::chrono::steady_clock::time_point window_;
      std::uint64_t                         window_ticks_ = 0;
      TripleBuffer<TickOutputs>             exchange_;
    };

    // The page's source of frames: built on the display thread, sent by the server thread.
    class RunView : public modalrt_tool::RunObserver, public FrameSource
    {
    public:
      // `mouse` null: watch-only (the HIPs belong to the session file or the UDP device).
      RunView(const ViewContext &context, MouseDevice *mouse, const ServerOptions &options)
        : context_(context), mouse_(mouse), ticks_(context.kernel), builder_(context.basis, context.hips, context.validity_level),
          server_(context.basis, context.basis_path, *this, options)
      {
        // Until the first snapshot the page gets no frame, and /api/state says so.
        state_ = dump_json(Json{{"tick", nullptr}});
        server_.start();
      }
      ~RunView() override { server_.stop(); }

      std::string url() const { return server_.url(); }
      std::size_t basis_bytes() const { return server_.basis_bytes(); }

      void ticked(const TickTiming &timing, const modalrt_hip_output *outputs, std::uint32_t hips) override
      {
        ticks_.ticked(timing, outputs, hips);
      }

      // Display thread.
      void displayed(const modalrt_snapshot *snapshot) override
      {
        ticks_.read(outputs_);
        builder_.update(snapshot, outputs_.tick, outputs_.out);
        bytes_.clear();
        builder_.frame(bytes_);
        std::string json = builder_.state_json();
        {
          std::lock_guard<std::mutex> lock(mutex_); // display and server threads only
          frame_.swap(bytes_);
          state_.swap(json);
          fresh_ = true;
        }
        server_.publish();
      }

      // Server thread.
      bool frame(std::vector<unsigned char> &bytes) override
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!fresh_)
          return false;
        fresh_ = false;
        bytes  = frame_;
        return true;
      }
      std::string state_json() override
      {
        std::lock_guard<std::mutex> lock(mutex_);
        return state_;
      }
      std::string command(const std::string &text) override
      {
        if (mouse_)
          return mouse_->command(text);
        return "error: watch-only: the HIPs of `modal-rt " + context_.command + "` are driven by " +
               (context_.command == "serve" ? "the UDP device" : "the session file") + "; " +
               quoted_page_message(text.data(), text.size()) + " ignored";
      }
      std::string session_json() override
      {
        Json j;
        j["driver"]         = mouse_ ? std::string("mouse") : context_.command;
        j["watch_only"]     = mouse_ == nullptr;
        j["hips"]           = context_.hips;
        j["contact"]        = context_.proxy ? "proxy" : "snap";
        j["validity_level"] = context_.validity_level;
        j["validity_clamp"] = context_.validity_clamp;
        return dump_json(j);
      }

    private:
      ViewContext                context_;
      MouseDevice               *mouse_;
      TickPublisher              ticks_;
      FrameBuilder               builder_; // display thread's
      TickOutputs                outputs_; // display thread's
      std::vector<unsigned char> bytes_;   // display thread's
      std::mutex                 mutex_;
      std::vector<unsigned char> frame_;
      std::string                state_;
      bool                       fresh_ = false;
      ViewServer                 server_; // last: stopped before the rest is destroyed
    };

    std::unique_ptr<RunView> start_view(const ViewContext &context, MouseDevice *mouse, const ServerOptions &options,
                                        std::string &error)
    {
      if (context.hips > run_view_max_hips)
        {
          error = "--view: the view shows at most " + std::to_string(run_view_max_hips) + " HIPs, the session has " +
                  std::to_string(context.hips);
          return nullptr;
        }
      try
        {
          return std::make_unique<RunView>(context, mouse, options);
        }
      catch (const std::exception &e)
        {
          error = e.what();
          return nullptr;
        }
    }
  } // namespace

  std::unique_ptr<modalrt_tool::RunObserver> start_watch_view(const ViewContext &context, unsigned port,
                                                              std::string &error)
  {
    ServerOptions options;
    options.port = port;
    auto view    = start_view(context, nullptr, options, error);
    if (view)
      std::printf("view: %s (watch-only: the browser watches `modal-rt %s`; the token is this run's)\n",
                  view->url().c_str(), context.command.c_str());
    std::fflush(stdout);
    return view;
  }

  std::unique_ptr<modalrt_tool::RunObserver> start_mouse_view(const ViewContext &context, MouseDevice &mouse,
                                                              const ServerOptions &options, std::string &error)
  {
    auto view = start_view(context, &mouse, options, error);
    if (view)
      std::printf("view: %s (basis %s, %zu bytes sent once per browser; the token is this run's; Ctrl-C stops)\n",
                  view->url().c_str(), context.basis_path.c_str(), view->basis_bytes());
    std::fflush(stdout);
    return view;
  }
} // namespace modalrt_view
