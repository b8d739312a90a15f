// The files `modal-rt run` writes into --output-dir, each to a temporary file then renamed (a
// reader never sees half a file): stats.json, trace.csv, presses.csv, slides.csv, frames.pvd and
// frames/frame_*.vtu; and force_displacement.png, drawn by scripts/plot_force_displacement.py.
#pragma once

#include "run_loop.h"

#include <modalrt/modalrt.h>

#include <cmath>
#include <string>
#include <vector>

namespace modalrt_tool
{
  // Writes `text` to `path` through a temporary file and a rename (mrt/atomic_file.h). false and a
  // message on failure.
  bool write_file_atomically(const std::string &path, const std::string &text, std::string &error);

  // VTU frames of the display surface, the arrays appended raw (format="appended", encoding="raw",
  // header_type="UInt64", the machine's byte order; docs/precompute.md): world positions at rest
  // (the frame's pose applied) and the point field "displacement" [m] (world axes), as Float32, for
  // ParaView's Warp By Vector. The cells, the vertex regions and the XML do not change from frame to
  // frame and are made once.
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
    std::string   cells_and_regions_; // their appended blocks, byte counts included
    std::string   xml_;               // from <VTKFile> to the appended block's '_'

  };

  // frames.pvd: the frames as a time series.
  bool write_pvd(const std::string &path, const std::vector<FrameRecord> &frames, std::string &error);

  // trace.csv: one row per decimated tick, the HIPs' columns side by side; along the normal of each
  // contact's load point, the normal and friction forces and the static and felt stiffness (from
  // `basis`; `impedance`: the trace's force is the one rendered on the device).
  // `validity_level` [%]: the kernel's (its flag's) level, for the validity force at each contact.
  // `design_b`: the second design's basis (two designs felt in turn): rows of design B are referenced
  // against it, and the columns design and design_b_share close each row.
  bool write_trace(const std::string &path, const HapticResult &result, std::uint32_t hip_count,
                   const modalrt_basis *basis, bool impedance, std::uint32_t validity_level, std::string &error,
                   const modalrt_basis *design_b = nullptr);
  // The validity force [N] at a trace row's contact at `level` [%] (stiffness_map.h's
  // contact_validity_force); NaN out of contact or without one.
  double trace_validity_force(const modalrt_basis *basis, const TraceSample &s, std::uint32_t level);

  // The name of every space of the basis, safe in a CSV field.
  std::vector<std::string> space_names(const modalrt_basis *basis);

  // A slide against the validity map at the kernel's level: its lowest margin, the smallest ratio
  // validity force / |F| over the slide's trace rows in contact (below 1: beyond), and where. Taken
  // after the run from the trace (at its rate), as the presses' validity: the haptic thread's
  // SlideTracker counts the slide's ticks flagged MODALRT_HIP_BEYOND_VALIDITY (Slide::beyond_ticks).
  struct SlideMargin
  {
    double        margin         = std::nan(""); // [-] validity_force / |F|; NaN: no row with a value and a force
    double        time           = std::nan(""); // [s] its trace row
    std::uint32_t vertex         = MODALRT_NONE; // the active vertex there (the heaviest corner of the proxy's triangle)
    std::uint32_t triangle       = MODALRT_NONE; // the proxy's triangle there
    double        force          = std::nan(""); // [N] |F| there
    double        validity_force = std::nan(""); // [N] trace_validity_force there
  };

  // Per slide of result.slides (in their order), its lowest margin at the kernel's `validity_level`.
  std::vector<SlideMargin> find_slide_margins(const HapticResult &result, std::uint32_t hip_count,
                                              const modalrt_basis *basis, std::uint32_t validity_level);

  // slides.csv: one row per slide (slides.h) and its margin (`margins`, one per slide), the space
  // names from `space_names`.
  bool write_slides(const std::string &path, const std::vector<Slide> &slides, const std::vector<SlideMargin> &margins,
                    std::uint32_t validity_level, const std::vector<std::string> &space_names, std::string &error);

  // One press: a contact period of one HIP (consecutive trace rows in contact at the same active
  // vertex, outside its slides), what it felt like, and the static stiffness of that contact (a proxy
  // contact: at the proxy's point, its rest position and blended normal). Along the vertex's outward
  // normal n (rest normal; sessions translate the part, so it is also the world normal): the force
  // pushes into the part and the active vertex is displaced into it, both counted positive.
  struct Press
  {
    std::uint32_t hip = 0, vertex = 0;
    std::uint32_t design = 0;          // two designs felt in turn: 0 A (--basis), 1 B (--design-b); vertex,
                                       // space and the static reference are of its basis
    std::uint32_t space = 0;           // active space at the press's last row (the compliance's space)
    std::string   space_name;
    std::size_t   first_row = 0, last_row = 0; // trace rows
    double        start = 0.0, end = 0.0;      // [s] first and last trace row in contact
    double        normal[3] = {0, 0, 0};       // [-] outward unit normal of the vertex (a proxy: its point's)
    double        rest[3]   = {0, 0, 0};       // [m] rest position of the vertex (a proxy: its point's), body frame
    double        compliance = 0.0;            // [m/N] n^T G n (modalrt_basis_contact_compliance, a proxy:
                                               //       modalrt_basis_point_compliance); NaN if none
    bool          full_fe    = false;          // G is the full-FE compliance (a candidate vertex)
    std::uint32_t max_contacts = 0;            // HIPs in contact at once during the press
    double        felt_time = 0.0;             // [s] end of the push: the last local maximum of the normal
                                               //     force that reaches half the press's largest force
    double        felt_force = 0.0;            // [N] normal force there
    double        felt_displacement = 0.0;     // [m] normal displacement there
    double        felt_stiffness = 0.0;        // [N/m] at the contact: the force on the part (felt_force /
                                               //       the haptic mapping's force scale) / felt_displacement
                                               //       (NaN if not pushed in)
    double        hand_travel = 0.0;           // [m] the device's own travel into the surface along n there
                                               //     (device units: -n . (hip - frame - rest))
    double        hand_stiffness = std::nan(""); // [N/m] at the hand: felt_force / hand_travel
    // Several HIPs in contact at the felt time: the static answer to all their loads at once (the
    // forces of that trace row, each at its own vertex), u_n = n^T sum_b G_ab F_b, from a kernel
    // settled to its exact static equilibrium under them. It is the full-FE answer when every
    // contact is a candidate of the space and every pair's cross compliance is stored; a pair the
    // space's far field couples (FAR_COMPLIANCE) gives the kernel's approximation of it.
    std::uint32_t felt_contacts = 0;           // [-] HIPs in contact at the felt time
    std::string   other_vertices;              // their other active vertices, ';'-separated
    double        multi_stiffness = std::nan(""); // [N/m] felt_force / u_n of that static answer; NaN if one contact
    bool          multi_full_fe   = false;     // every pair has its full-FE cross compliance
    std::uint32_t multi_far_rank  = 0;         // > 0: no pair uncoupled, some coupled by the far field of this rank
    std::string   multi_note;                  // why not full FE ("" when it is)
    // The validity map at the kernel's level (MODALRT_HIP_BEYOND_VALIDITY), from the trace's rows.
    double        max_force = 0.0;             // [N] largest |F| of the press's rows
    double        validity_force = std::nan(""); // [N] at the press's point (its last row); NaN: no value
    bool          beyond = false;              // a row of the press flagged MODALRT_HIP_BEYOND_VALIDITY
    double        beyond_time  = std::nan("");  // [s] its first such row
    double        beyond_force = std::nan("");  // [N] |F| there
  };

  // The presses of a run, in order of start time. `impedance`: the trace's force is the one
  // rendered on the device (it pushes the hand out: +n), else the one applied to the part (-n).
  // `force_scale`: the haptic mapping's force commanded / force on the part (1 without a scale).
  std::vector<Press> find_presses(const HapticResult &result, std::uint32_t hip_count, const modalrt_basis *basis,
                                  bool impedance, std::uint32_t validity_level, double force_scale = 1.0);

  // presses.csv: one row per press (the columns are documented in realtime/README.md).
  bool write_presses(const std::string &path, const std::vector<Press> &presses, bool impedance,
                     std::uint32_t validity_level, std::string &error, double force_scale = 1.0);

  // Runs scripts/`script` (plot_force_displacement.py, plot_slide_stiffness.py) on the output directory
  // with /usr/bin/python3. Returns true when it wrote `picture`; else `notice` says why and how to make it.
  bool plot_run(const std::string &script, const std::string &picture, const std::string &output_dir,
                std::string &notice);

  // Percentile p (0..100) of the values (nearest rank); 0 for none.
  double percentile(std::vector<float> values, double p);

  // What stats.json and the summary report.
  struct RunReport
  {
    std::string         command, basis, session, output_dir, mode, device, stopped_by; // command: run or serve
    double              rate = 0.0, duration = 0.0;
    std::uint32_t       hips = 0;
    double              latency_p50 = 0, latency_p99 = 0, latency_p999 = 0, latency_max = 0; // [us]
    double              jitter_p50 = 0, jitter_p99 = 0, jitter_p999 = 0, jitter_max = 0;     // [us]
    modalrt_kernel_stats kernel{};
    const HapticResult  *haptic  = nullptr;
    const DisplayResult *display = nullptr;
    double              max_press_distance = 0.0; // [m] press points to their vertices
    double              coupling_stiffness = 0.0, coupling_damping = 0.0, snap_distance = 0.0;
    std::vector<std::pair<std::string, std::uint64_t>> device_counters; // packets, ... (serve)
    std::vector<Press>  presses;
    std::vector<SlideMargin> slide_margins; // per slide of haptic->slides
    std::vector<std::string> space_names; // per space of the basis (the slides' spaces)
    bool                plot_written = false; // force_displacement.png
    bool                slide_plot_written = false; // slide_stiffness.png
    std::uint32_t       validity_level = 5;     // [%] the kernel's (modalrt_kernel_def.validity_level)
    bool                validity_clamp = false; // modalrt_kernel_def.validity_clamp
    bool                validity_map   = false; // the basis has a validity map (has_validity_map)
    std::string         profile;                // --device/--profile NAME ("" none)
    modalrt_haptic_mapping mapping{};           // the kernel's (modalrt_kernel_get_haptic_mapping)
    std::string         scale_line;             // "1 N/mm at the hand = ..." ("" without a scale)
    std::string         design_b;               // --design-b FILE ("": one design)
    double              design_fade = 0.0;      // [s] --fade
    bool                blind       = false;    // --blind
    std::uint32_t       blind_seed  = 0;
  };

  RunReport   summarize(const HapticResult &haptic, double rate);
  std::string stats_json(const RunReport &report);
  void        print_summary(const RunReport &report);
} // namespace modalrt_tool
