#include "run_view.h"

#include "frame_builder.h"
#include "triple_buffer.h"
#include "view_server.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace modalrt_view
{
  namespace
  {
    using modalrt_tool::Device;

    // What the haptic thread publishes after each tick.
    struct TickOutputs
    {
      HapticTick         tick;
      modalrt_hip_output out[run_view_max_hips] = {};
    };

    // The session's device, unchanged, plus a wait-free copy of each tick's outputs for the view.
    // Tick duration here is the device's view of the tick: read_state to end_tick (device read,
    // kernel tick, device writes); the wake-up lateness is not seen here (NaN; stats.json has the
    // run's own latency figures).
    class WatchedDevice : public Device
    {
    public:
      WatchedDevice(std::unique_ptr<Device> inner, modalrt_kernel *kernel)
        : inner_(std::move(inner)), kernel_(kernel), hips_(inner_->hip_count())
      {
        close_window(state_.tick.stats, durations_, nullptr, 0, 1.0); // lateness: NaN from the start
      }

      bool              open(std::string &error) override { return inner_->open(error); }
      void              close() override { inner_->close(); }
      const modalrt_tool::DeviceSpec &spec() const override { return inner_->spec(); }
      std::uint32_t     hip_count() const override { return hips_; }
      bool read_state(double t, modalrt_hip_input *inputs) override
      {
        begin_ = Clock::now();
        return inner_->read_state(t, inputs);
      }
      void write_force(std::uint32_t hip, const double force[3]) override { inner_->write_force(hip, force); }
      void track_position(std::uint32_t hip, const double position[3], const double velocity[3],
                          bool in_contact) override
      {
        inner_->track_position(hip, position, velocity, in_contact);
      }
      void report_output(std::uint32_t hip, const modalrt_hip_output &output) override
      {
        state_.out[hip] = output;
        inner_->report_output(hip, output);
      }
      void end_tick() override
      {
        inner_->end_tick();
        const Clock::time_point end = Clock::now();
        durations_.add(std::chrono::duration<double, std::micro>(end - begin_).count());
        if (window_ticks_++ == 0)
          window_ = begin_;
        if (end - window_ >= std::chrono::seconds(1))
          {
            close_window(state_.tick.stats, durations_, nullptr, window_ticks_,
                         std::chrono::duration<double>(end - window_).count());
            window_ticks_ = 0;
          }
        stamp_tick(kernel_, state_.tick);
        exchange_.publish(state_);
      }
      std::vector<std::pair<std::string, std::uint64_t>> counters() const override { return inner_->counters(); }

      // Display thread: the newest tick's outputs.
      void read(TickOutputs &outputs) { exchange_.read(outputs); }

    private:
      using Clock = std::chrono::steady_clock;
      std::unique_ptr<Device>  inner_;
      modalrt_kernel          *kernel_;
      std::uint32_t            hips_;
      TickOutputs              state_; // haptic thread's
      TickHistogram            durations_;
      Clock::time_point        begin_, window_;
      std::uint64_t            window_ticks_ = 0;
      TripleBuffer<TickOutputs> exchange_;
    };

    class RunView : public modalrt_tool::DisplayObserver, public FrameSource
    {
    public:
      RunView(const modalrt_basis *basis, const std::string &basis_path, WatchedDevice &device, unsigned port,
              const std::string &driver)
        : device_(device), builder_(basis, device.hip_count()), driver_(driver),
          server_(basis, basis_path, *this, [port] {
            ServerOptions o;
            o.port = port;
            return o;
          }())
      {
        // Until the first snapshot the page gets no frame, and /api/state says so.
        state_ = "{\"tick\":null}";
        server_.start();
      }
      ~RunView() override { server_.stop(); }

      unsigned port() const { return server_.port(); }

      // Display thread.
      void displayed(const modalrt_snapshot *snapshot) override
      {
        device_.read(outputs_);
        builder_.update(snapshot, outputs_.tick, outputs_.out);
        bytes_.clear();
        builder_.frame(bytes_);
        std::string json = builder_.state_json();
        std::lock_guard<std::mutex> lock(mutex_); // display and server threads only
        frame_.swap(bytes_);
        state_.swap(json);
        fresh_ = true;
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
        return "error: watch-only: the HIPs of `modal-rt " + driver_ + "` are driven by " +
               (driver_ == "serve" ? "the UDP device" : "the session file") + "; '" + text + "' ignored";
      }
      std::string session_json() override
      {
        return "{\"driver\":\"" + driver_ + "\",\"watch_only\":true,\"hips\":" + std::to_string(device_.hip_count()) +
               "}";
      }

    private:
      WatchedDevice             &device_;
      FrameBuilder               builder_; // display thread's
      TickOutputs                outputs_; // display thread's
      std::vector<unsigned char> bytes_;   // display thread's
      std::string                driver_;
      std::mutex                 mutex_;
      std::vector<unsigned char> frame_;
      std::string                state_;
      bool                       fresh_ = false;
      ViewServer                 server_; // last: stopped before the rest is destroyed
    };
  } // namespace

  std::unique_ptr<modalrt_tool::DisplayObserver>
  start_run_view(const modalrt_basis *basis, const std::string &basis_path, modalrt_kernel *kernel,
                 std::unique_ptr<modalrt_tool::Device> &device, unsigned port, const std::string &driver,
                 std::string &error)
  {
    if (device->hip_count() > run_view_max_hips)
      {
        error = "--view: the view shows at most " + std::to_string(run_view_max_hips) + " HIPs, the session has " +
                std::to_string(device->hip_count());
        return nullptr;
      }
    try
      {
        auto watched = std::make_unique<WatchedDevice>(std::move(device), kernel);
        auto view    = std::make_unique<RunView>(basis, basis_path, *watched, port, driver);
        device       = std::move(watched);
        std::printf("view: http://127.0.0.1:%u/ (watch-only: the browser watches `modal-rt %s`)\n", view->port(),
                    driver.c_str());
        std::fflush(stdout);
        return view;
      }
    catch (const std::exception &e)
      {
        error = e.what();
        return nullptr;
      }
  }
} // namespace modalrt_view
