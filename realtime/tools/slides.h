// The slides of a run: a HIP's proxy (MODALRT_CONTACT_PROXY) moving over the part. A slide runs from
// the first tick a HIP's proxy slides (MODALRT_HIP_SLIDING) to the last one it slides in the same
// contact; sticking ticks between two sliding ones belong to it. The tracker sees every tick in the
// haptic thread (no allocation: the records are sized before the first tick), so the length, the
// largest force change per tick, the energy and the ticks beyond the validity force are per tick,
// not per trace row. (The lowest validity margin along the path needs the basis' validity map: it is
// taken after the run from the trace, run_outputs.h's find_slide_margins.)
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>
#include <vector>

namespace modalrt_tool
{
  // [m] A proxy that moves less than this over the part while sliding is a press's creep (the contact
  // point settling as the tangential force builds on landing), not a slide: its rows stay the
  // press's. A fingertip's contact patch is millimetres wide; the display's finest edges about 1.5 mm.
  constexpr double min_slide_length = 1e-3;

  struct Slide
  {
    std::uint32_t hip         = 0;
    double        start       = 0.0, end = 0.0; // [s] first and last sliding tick
    std::uint32_t space_start = 0, space_end = 0; // active space at those ticks
    std::uint64_t ticks       = 0; // from start to end
    std::uint64_t sliding_ticks = 0; // of those, flagged MODALRT_HIP_SLIDING
    double        length      = 0.0; // [m] path of the proxy over the part: of its point on the surface at rest
                                     // (its triangle and weights), so the part's own deformation under a
                                     // press is not counted as sliding
    double        max_force_step = 0.0; // [N] largest |F_n - F_(n-1)| between consecutive ticks of the slide
    double        max_force   = 0.0; // [N] largest |F|
    std::uint64_t beyond_ticks = 0; // of `ticks`, flagged MODALRT_HIP_BEYOND_VALIDITY (a basis with a validity map)
    // [J] the passivity observer of realtime/README.md for this HIP over the slide's ticks: the work the
    // hand did on the kernel, sum of -F_(n-1) . (x_n - x_(n-1)) (F the force on the device, x the HIP);
    // impedance ticks without the fail-safe rule only, as the kernel's.
    double        energy      = 0.0;
  };

  class SlideTracker
  {
  public:
    // Room for `capacity` slides (allocates; before the first tick). Slides past it are counted in dropped().
    void reset(std::uint32_t hips, std::size_t capacity, bool impedance);
    // Haptic thread, after each tick: the tick's inputs and outputs, the part frame's origin [m] and the
    // basis the outputs' proxy triangles are of. No allocation.
    void observe(double t, const modalrt_hip_input *inputs, const modalrt_hip_output *outputs, const double frame[3],
                 const modalrt_basis *basis);
    // After the last tick: the slides in order of start (an open one ends at its last sliding tick).
    std::vector<Slide> finish();
    std::uint64_t      dropped() const { return dropped_; }
    std::uint64_t      creeps() const { return creeps_; } // sliding shorter than min_slide_length, not recorded

  private:
    // One HIP: its slide in progress and what happened since its last sliding tick (committed to the
    // slide when it slides again, dropped when the contact ends first).
    struct Track
    {
      bool   open = false;
      Slide  slide;
      double pending_length = 0.0, pending_step = 0.0, pending_force = 0.0, pending_energy = 0.0;
      std::uint64_t pending_ticks = 0, pending_beyond = 0;
      bool   have_previous = false; // the previous tick was observed in contact
      double point[3] = {0, 0, 0}, force[3] = {0, 0, 0}, hip[3] = {0, 0, 0};
    };
    void close(Track &track);

    std::vector<Track> tracks_;
    std::vector<Slide> slides_;
    std::size_t        capacity_  = 0;
    std::uint64_t      dropped_   = 0;
    std::uint64_t      creeps_    = 0;
    bool               impedance_ = true;
  };
} // namespace modalrt_tool
