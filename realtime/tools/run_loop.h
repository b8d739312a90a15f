// The two threads of `modal-rt run` (and `serve`, and the view's `modal-rt view`).
//
// Haptic thread: one kernel tick per period on an absolute schedule (sleep until shortly before the
// deadline, then spin), with SCHED_FIFO when the system grants it. Each tick applies the session's
// events and frame, reads the device, ticks the kernel, writes the device, and records its latency
// (wake-up to force written) and its start time into arrays sized before the first tick. A tick that
// ends after the next deadline is an overrun; when more than a whole period is lost the schedule
// restarts from now (missed periods are counted; no burst of catch-up ticks). Simulated time is
// tick count x period, so a session always runs rate x duration ticks.
//
// Display thread: at 60 Hz (its rate), reads the kernel's snapshot (lock-free) and reconstructs the display
// surface; every 1/frame_rate s of simulated time it writes that surface as a VTU frame.
//
// This is the tool's one haptic loop: `run`, `serve` and the view's mouse (`modal-rt view`) all tick
// here, with their own Device; a RunObserver (the browser view) watches both threads.
#pragma once

#include "design_pair.h"
#include "devices.h"
#include "session.h"
#include "slides.h"

#include <modalrt/modalrt.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace modalrt_tool
{
  // One decimated tick of one HIP, for trace.csv.
  struct TraceSample
  {
    double        time;         // [s] simulated
    double        hip[3];       // [m] device (HIP) position, world
    double        contact[3];   // [m] output position: the felt contact point in contact, else the HIP
    double        force[3];     // [N] impedance: rendered on the device; admittance: applied to the part
    double        frame[3];     // [m] world position of the part frame's origin (the felt displacement
                                //     of a carried part is contact - frame - rest)
    std::uint32_t in_contact;
    std::uint32_t active_vertex; // MODALRT_NONE when not in contact
    std::uint32_t space;
    std::uint32_t flags;         // MODALRT_HIP_* of that tick (presses.csv skips FAIL_SAFE and FORCE_RAMPING)
    std::uint32_t proxy_triangle   = MODALRT_NONE; // proxy contact: its display triangle
    double        proxy_weights[3] = {0.0, 0.0, 0.0}; // [-] its barycentric weights there
    std::uint32_t design           = 0;    // two designs: the one in front (0 A, 1 B); vertex, space and
                                           // proxy are of its basis
    float         design_share     = 0.0f; // [-] two designs: B's share of the output (0 < share < 1: a fade)
  };

  struct HapticSettings
  {
    double        rate       = 1000.0; // [Hz]
    std::uint64_t tick_limit = 0;      // ticks of the session (rate x duration)
    bool          impedance  = true;
    std::uint32_t trace_decimation = 10; // a trace row every this many ticks
    double        spin_us          = 100.0; // [us] sleep until this long before a deadline, then spin
    // Keep each tick's latency and period and the trace rows (arrays sized from tick_limit before
    // the first tick). false for a session without outputs that may run until Ctrl-C (the view).
    bool          record           = true;
  };

  struct HapticResult
  {
    std::uint64_t ticks           = 0;
    std::uint64_t overruns        = 0; // ticks that ended after the next deadline
    std::uint64_t missed_periods  = 0; // whole periods lost when the schedule restarted
    std::uint64_t non_finite_outputs = 0; // output values that are NaN or infinite
    std::uint64_t failed_events   = 0; // press/release calls the kernel refused
    std::uint64_t events_applied  = 0;
    std::uint64_t allocations     = 0; // in the haptic thread, first tick to last
    std::vector<std::uint64_t> beyond_validity_ticks; // per HIP: ticks flagged MODALRT_HIP_BEYOND_VALIDITY
    bool          interrupted     = false; // stopped by SIGINT/SIGTERM
    bool          realtime_priority = false; // SCHED_FIFO granted
    double        wall_seconds    = 0.0;
    std::vector<float> latency_us; // per tick: wake-up to device written
    std::vector<float> period_us;  // per tick: start minus the previous tick's start
    std::vector<TraceSample> trace; // decimation rows x HIPs
    std::vector<Slide>       slides; // every tick's proxies, in order of start (slides.h)
    std::uint64_t            slides_dropped = 0; // beyond the records' capacity
    std::uint64_t            creeps         = 0; // sliding shorter than min_slide_length: part of a press
    std::vector<modalrt_hip_input>  last_inputs;
    std::vector<modalrt_hip_output> last_outputs;
    std::uint64_t                   design_switches = 0; // two designs: `design` and `present` events
    std::vector<BlindTrial>         trials;              // the blind mode's trials
  };

  // The second design of `modal-rt run --design-b` (design_pair.h): its kernel and basis, the fade
  // between the two, and the blind mode's seed. Its kernel sees every input and event the first sees.
  struct SecondDesign
  {
    modalrt_kernel      *kernel = nullptr;
    const modalrt_basis *basis  = nullptr;
    double               fade   = 0.25; // [s] from one design to the other
    bool                 blind  = false;
    std::uint32_t        seed   = 0;
  };

  struct FrameRecord
  {
    double      time; // [s] simulated time of the snapshot
    std::string file; // relative to the output directory
  };

  // When the haptic thread woke up for a tick and when the tick was done.
  struct TickTiming
  {
    std::chrono::steady_clock::time_point deadline; // the tick's scheduled start
    std::chrono::steady_clock::time_point begin;    // wake-up
    std::chrono::steady_clock::time_point end;      // device written
  };

  // Watches a run from beside it (the live browser view of --view and `modal-rt view`, view/run_view.h):
  // the haptic thread hands it each tick's outputs, the display thread each new snapshot it reads,
  // so the kernel keeps one snapshot reader.
  class RunObserver
  {
  public:
    virtual ~RunObserver() = default;
    // Haptic thread, after each tick: wait-free, no allocation, no I/O.
    virtual void ticked(const TickTiming &timing, const modalrt_hip_output *outputs, std::uint32_t hips) = 0;
    // Display thread, after each snapshot read that brought a new state.
    virtual void displayed(const modalrt_snapshot *snapshot) = 0;
  };

  struct DisplaySettings
  {
    std::string output_dir;
    double      rate        = 60.0; // [Hz] snapshots read
    double      frame_rate  = 10.0; // [Hz] of simulated time: frames written (0: none)
    bool        reconstruct = true; // the whole surface on the CPU at each read (false: the view alone
                                    // draws it, on the GPU)
  };

  struct DisplayResult
  {
    std::uint64_t            reconstructions = 0;
    double                   max_reconstruct_ms = 0.0;
    std::vector<FrameRecord> frames;
    std::string              error; // first frame that could not be written
  };

  // Installs the SIGINT/SIGTERM handler that asks both loops to stop (a second Ctrl-C kills).
  void install_stop_handler();
  bool stop_requested();

  // Runs both threads to the end of the session or a stop request; returns when both are done.
  // `observer` (may be null) watches them; `second` (may be null) is a second design felt in turn.
  void run_threads(modalrt_kernel *kernel, const modalrt_basis *basis, Device &device, const Session &session,
                   const HapticSettings &haptic, const DisplaySettings &display, RunObserver *observer,
                   HapticResult &haptic_result, DisplayResult &display_result, const SecondDesign *second = nullptr);
} // namespace modalrt_tool
