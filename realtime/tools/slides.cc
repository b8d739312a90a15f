#include "slides.h"

#include <algorithm>
#include <cmath>

namespace modalrt_tool
{
  void SlideTracker::reset(std::uint32_t hips, std::size_t capacity, bool impedance)
  {
    tracks_.assign(hips, Track{});
    slides_.clear();
    slides_.reserve(capacity);
    capacity_  = capacity;
    dropped_   = 0;
    creeps_    = 0;
    impedance_ = impedance;
  }

  void SlideTracker::close(Track &track)
  {
    if (track.open && track.slide.length < min_slide_length)
      ++creeps_;
    else if (track.open)
      {
        if (slides_.size() < capacity_)
          slides_.push_back(track.slide); // within the reserved capacity: no allocation
        else
          ++dropped_;
      }
    track = Track{};
  }

  namespace
  {
    // Where a contact is on the part at rest: a proxy's point from its triangle and weights, else the
    // output position in the body frame.
    void rest_point(const modalrt_hip_output &o, const double frame[3], const modalrt_basis *basis, double point[3])
    {
      if (o.proxy_triangle == MODALRT_NONE || !basis)
        {
          for (int d = 0; d < 3; ++d)
            point[d] = o.position[d] - frame[d];
          return;
        }
      const std::uint32_t *corners = modalrt_basis_display_triangles(basis) + 3 * std::size_t(o.proxy_triangle);
      const double        *x       = modalrt_basis_display_vertices(basis);
      for (int d = 0; d < 3; ++d)
        point[d] = o.proxy_weights[0] * x[3 * std::size_t(corners[0]) + d] +
                   o.proxy_weights[1] * x[3 * std::size_t(corners[1]) + d] +
                   o.proxy_weights[2] * x[3 * std::size_t(corners[2]) + d];
    }
  } // namespace

  void SlideTracker::observe(double t, const modalrt_hip_input *inputs, const modalrt_hip_output *outputs,
                             const double frame[3], const modalrt_basis *basis)
  {
    for (std::uint32_t h = 0; h < tracks_.size(); ++h)
      {
        Track                    &k = tracks_[h];
        const modalrt_hip_output &o = outputs[h];
        if (!o.in_contact)
          {
            close(k);
            continue;
          }
        double point[3], step2 = 0.0, moved2 = 0.0, work = 0.0, force2 = 0.0;
        rest_point(o, frame, basis, point);
        for (int d = 0; d < 3; ++d)
          {
            step2 += (o.force[d] - k.force[d]) * (o.force[d] - k.force[d]);
            moved2 += (point[d] - k.point[d]) * (point[d] - k.point[d]);
            work -= k.force[d] * (inputs[h].position[d] - k.hip[d]);
            force2 += o.force[d] * o.force[d];
          }
        const bool observed = impedance_ && !(o.flags & MODALRT_HIP_FAIL_SAFE);
        if (k.have_previous)
          {
            k.pending_length += std::sqrt(moved2);
            k.pending_step = std::max(k.pending_step, std::sqrt(step2));
            k.pending_energy += observed ? work : 0.0;
          }
        const bool beyond = (o.flags & MODALRT_HIP_BEYOND_VALIDITY) != 0;
        k.pending_force   = std::max(k.pending_force, std::sqrt(force2));
        ++k.pending_ticks;
        k.pending_beyond += beyond;
        k.have_previous = true;
        std::copy_n(point, 3, k.point);
        std::copy_n(o.force, 3, k.force);
        std::copy_n(inputs[h].position, 3, k.hip);
        if (!(o.flags & MODALRT_HIP_SLIDING))
          continue;
        if (!k.open) // the slide starts here: what came before it is not part of it
          {
            k.open              = true;
            k.slide             = Slide{};
            k.slide.hip         = h;
            k.slide.start       = t;
            k.slide.space_start = o.space;
            k.pending_length = k.pending_step = k.pending_energy = 0.0;
            k.pending_force = std::sqrt(force2);
            k.pending_ticks  = 1;
            k.pending_beyond = beyond;
          }
        Slide &s = k.slide;
        s.end       = t;
        s.space_end = o.space;
        s.ticks += k.pending_ticks;
        s.beyond_ticks += k.pending_beyond;
        ++s.sliding_ticks;
        s.length += k.pending_length;
        s.max_force_step = std::max(s.max_force_step, k.pending_step);
        s.max_force      = std::max(s.max_force, k.pending_force);
        s.energy += k.pending_energy;
        k.pending_length = k.pending_step = k.pending_force = k.pending_energy = 0.0;
        k.pending_ticks = k.pending_beyond = 0;
      }
  }

  std::vector<Slide> SlideTracker::finish()
  {
    for (Track &k : tracks_)
      close(k);
    std::vector<Slide> out = slides_;
    std::stable_sort(out.begin(), out.end(), [](const Slide &a, const Slide &b) { return a.start < b.start; });
    return out;
  }
} // namespace modalrt_tool
