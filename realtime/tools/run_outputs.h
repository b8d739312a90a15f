// The files `modal-rt run` writes into --output-dir, each to a temporary file then renamed (a
// reader never sees half a file): stats.json, trace.csv, frames.pvd and frames/frame_*.vtu.
#pragma once

#include "run_loop.h"

#include <modalrt/modalrt.h>

#include <string>
#include <vector>

namespace modalrt_tool
{
  // Writes `text` to `path` through `path`.tmp and a rename. false and a message on failure.
  bool write_file_atomically(const std::string &path, const std::string &text, std::string &error);

  // ASCII VTU frames of the display surface: world positions at rest (the frame's pose applied) and
  // the point field "displacement" [m] (world axes), for ParaView's Warp By Vector. The cells and
  // the vertex regions do not change and are formatted once.
  class VtuFrameWriter
  {
  public:
    explicit VtuFrameWriter(const modalrt_basis *basis);
    bool write(const std::string &path, const modalrt_snapshot_info &info, const float *displacements,
               std::string &error) const;

  private:
    const double *rest_;
    std::uint32_t vertex_count_;
    std::uint32_t triangle_count_;
    std::string   cells_and_regions_;
  };

  // frames.pvd: the frames as a time series.
  bool write_pvd(const std::string &path, const std::vector<FrameRecord> &frames, std::string &error);

  // trace.csv: one row per decimated tick, the HIPs' columns side by side.
  bool write_trace(const std::string &path, const HapticResult &result, std::uint32_t hip_count, std::string &error);

  // Percentile p (0..100) of the values (nearest rank); 0 for none.
  double percentile(std::vector<float> values, double p);

  // What stats.json and the summary report.
  struct RunReport
  {
    std::string         command, basis, session, output_dir, mode, device, stopped_by; // command: run or serve
    double              rate = 0.0, duration = 0.0;
    std::uint32_t       hips = 0;
    double              latency_p50 = 0, latency_p99 = 0, latency_p999 = 0, latency_max = 0; // [us]
    double              jitter_p99 = 0, jitter_max = 0;                                      // [us]
    modalrt_kernel_stats kernel{};
    const HapticResult  *haptic  = nullptr;
    const DisplayResult *display = nullptr;
    double              max_press_distance = 0.0; // [m] press points to their vertices
    double              coupling_stiffness = 0.0, coupling_damping = 0.0, snap_distance = 0.0;
    std::vector<std::pair<std::string, std::uint64_t>> device_counters; // packets, ... (serve)
  };

  RunReport   summarize(const HapticResult &haptic, double rate);
  std::string stats_json(const RunReport &report);
  void        print_summary(const RunReport &report);
} // namespace modalrt_tool
