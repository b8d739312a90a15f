// The frames the page receives (view/README.md, "Frame") and the JSON of GET /api/state, built from
// a kernel snapshot and the haptic thread's HIP outputs. Used by every FrameSource: the mouse
// session of `modal-rt view` (server thread) and the live view of `run`/`serve` (display thread).
// Never used in a haptic thread (it allocates).
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>
#include <string>
#include <vector>

namespace modalrt_view
{
  // Tick durations and wake-up lateness over a window of ticks (no allocation: usable in a haptic
  // thread): 0.1 us bins up to 500 us, then 10 us bins up to 50 ms. The coarse bins are there for the
  // wake-up lateness: on a loaded machine more than 1 % of the ticks start over 500 us late (a
  // preempted thread catches up with several late ticks), and a histogram that ended at 500 us showed
  // a p99 of 499.9 us for ever. Beyond 50 ms a percentile is the window's max.
  struct TickHistogram
  {
    static constexpr int    fine_bins = 5000;                         // 0.1 us each, up to 500 us
    static constexpr int    bins      = fine_bins + (50000 - 500) / 10; // then 10 us each, up to 50 ms
    std::uint32_t           count[bins] = {};
    std::uint32_t           n           = 0;
    double                  max_us      = 0.0;

    void   add(double us);
    double percentile(double p) const;
    void   clear();
  };

  // What the haptic side measured: the frame's statistics block (NaN: not measured).
  struct TickStats
  {
    double tick_p50_us = 0, tick_p99_us = 0, tick_max_us = 0; // tick duration
    double late_p50_us = 0, late_p99_us = 0, late_max_us = 0; // tick start after its deadline
    double rate_hz     = 0;                                  // ticks per second of wall time
  };

  // The haptic thread's latest tick as the view needs it.
  struct HapticTick
  {
    std::uint64_t tick     = 0;   // kernel ticks done (modalrt_kernel_stats.tick_count)
    double        wall_ms  = 0.0; // [ms] since the epoch, end of that tick
    std::uint64_t rejected = 0;   // kernel's rejected ticks
    TickStats     stats;
  };

  // Haptic thread (no allocation): the statistics of a closed window of `ticks` ticks over `seconds`
  // of wall time, then the histograms cleared. `lateness` null: not measured (NaN).
  void close_window(TickStats &stats, TickHistogram &durations, TickHistogram *lateness, std::uint64_t ticks,
                    double seconds);
  // Haptic thread, after a tick: the kernel's counters and the wall clock.
  void stamp_tick(const modalrt_kernel *kernel, HapticTick &tick);

  class FrameBuilder
  {
  public:
    // `validity_level` [%]: the kernel's, for each contact's validity force (MODALRT_HIP_BEYOND_VALIDITY).
    FrameBuilder(const modalrt_basis *basis, std::uint32_t hips, std::uint32_t validity_level = 5);

    // After a snapshot was read: the HIPs' outputs of the haptic tick (`hips` of them).
    void update(const modalrt_snapshot *snapshot, const HapticTick &tick, const modalrt_hip_output *outputs);
    // The frame of the last update, appended to `bytes`.
    void        frame(std::vector<unsigned char> &bytes) const;
    std::string state_json() const;

  private:
    struct Hip
    {
      std::uint32_t in_contact = 0, vertex = MODALRT_NONE, full_fe = 0, space = MODALRT_NONE, flags = 0;
      std::uint32_t triangle = MODALRT_NONE; // a proxy's triangle and weights, of static_stiffness
      double        weights[3] = {};
      double        force[3] = {}, displacement[3] = {}, felt[3] = {};
      double        position[3] = {}; // [m] the output position: the felt point (a proxy's), else the HIP
      double        static_stiffness = 0.0; // [N/m] 1 / (n^T G n) along the normal (a proxy: at its point)
      double        validity_force   = 0.0; // [N] the validity map's at the contact, the kernel's level (0: none)
    };

    const modalrt_basis       *basis_;
    const double              *vertices_, *normals_;
    std::uint32_t              hips_;
    std::uint32_t              validity_level_;
    HapticTick                 tick_;
    modalrt_snapshot_info      info_{};
    std::vector<double>        q_;
    std::vector<Hip>           hip_;
    std::vector<std::uint32_t> contact_vertices_;
    std::vector<double>        contact_corrections_;
    std::uint32_t              contact_count_ = 0;
  };
} // namespace modalrt_view
