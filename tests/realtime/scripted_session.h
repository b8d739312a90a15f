// A scripted haptic session used by the determinism and no-allocation tests: two HIPs that touch,
// push, slide between VOIs (switches), release and come back, alternately in admittance and
// impedance, with a moving frame. Every output is folded into a hash (FNV-1a over the bytes).
#pragma once

#include "test_support.h"

#include <cstring>

namespace test
{
  struct Session
  {
    modalrt_basis  *basis  = nullptr;
    modalrt_kernel *kernel = nullptr;
    std::uint64_t   hash   = 1469598103934665603ull;
    std::uint64_t   beyond = 0; // HIP outputs flagged MODALRT_HIP_BEYOND_VALIDITY

    void fold(const void *data, std::size_t size)
    {
      const unsigned char *p = static_cast<const unsigned char *>(data);
      for (std::size_t i = 0; i < size; ++i)
        hash = (hash ^ p[i]) * 1099511628211ull;
    }
  };

  inline modalrt::LatticeOptions session_lattice()
  {
    modalrt::LatticeOptions o;
    o.patch_radius      = 0.03;
    o.float64_modes     = false;
    o.candidate_stride  = 2; // some vertices without correction
    o.stiffness_modulus = 2e7;
    return o;
  }

  // validity_level and validity_clamp as in modalrt_kernel_def (0, 0: the defaults).
  inline void open(Session &s, const modalrt::BasisContent &content, std::uint32_t validity_level = 0,
                   std::uint32_t validity_clamp = 0)
  {
    s.basis                  = load(content);
    modalrt_kernel_def def   = modalrt_kernel_default_def();
    def.hip_capacity         = 2;
    def.validity_level       = validity_level;
    def.validity_clamp       = validity_clamp;
    def.snap_distance        = 0.03; // the lattice display mesh is coarse (2.5 cm)
    s.kernel                 = create(s.basis, def);
  }

  inline void close(Session &s)
  {
    modalrt_kernel_destroy(s.kernel);
    modalrt_basis_destroy(s.basis);
  }

  // Ticks [first, last) of the script (no allocation, no I/O). HIP 0 presses for 400 ticks, lifts
  // off for 100 and lands elsewhere, alternately in the tip VOI and near the root; HIP 1 taps near
  // the root now and then. Both steps alternate every 2000 ticks.
  inline void run(Session &s, int first, int last)
  {
    const double top = modalrt_basis_display_vertices(s.basis)[2];
    for (int n = first; n < last; ++n)
      {
        const double t = 1e-3 * n;
        const int    cycle = n / 500, k = n % 500;
        modalrt_hip_input in[2];
        std::memset(in, 0, sizeof in);
        in[0].position[0] = 0.2 * (cycle % 2 == 0 ? 0.8 + 0.1 * std::sin(cycle) : 0.3 + 0.1 * std::cos(cycle));
        in[0].position[1] = 0.025 + 0.01 * std::sin(1.7 * cycle);
        if (k < 400)
          {
            in[0].position[2] = top - 0.0005 - 0.0003 * std::sin(5 * t);
            in[0].velocity[2] = -0.0015 * std::cos(5 * t);
            in[0].force[0]    = 0.1 * std::cos(2 * t);
            in[0].force[2]    = -0.5 - 0.3 * std::sin(3 * t);
          }
        else
          {
            in[0].position[2] = top + 0.005;
            in[0].force[2]    = 0.3; // pulls: releases an admittance contact
          }
        const bool tapping = n % 1500 < 600;
        in[1].position[0]  = 0.05;
        in[1].position[1]  = 0.025;
        in[1].position[2]  = top + (tapping ? -0.0008 : 0.005);
        in[1].force[2]     = tapping ? -0.3 : 0.3;
        if (n % 1000 == 0)
          {
            modalrt_frame_state f    = modalrt_frame_state_identity();
            f.linear_acceleration[2] = 2.0 * std::sin(t);
            f.angular_velocity[1]    = 0.1;
            modalrt_kernel_set_frame(s.kernel, &f);
          }
        if (n % 2500 == 1234)
          modalrt_kernel_release_hip(s.kernel, 1);
        modalrt_hip_output out[2];
        const bool         impedance = (n / 2000) % 2 == 1;
        const int status = impedance ? modalrt_kernel_tick_impedance(s.kernel, in, 2, out)
                                     : modalrt_kernel_tick_admittance(s.kernel, in, 2, out);
        s.fold(&status, sizeof status);
        for (const modalrt_hip_output &o : out)
          {
            s.fold(o.position, sizeof o.position);
            s.fold(o.velocity, sizeof o.velocity);
            s.fold(o.force, sizeof o.force);
            s.fold(&o.in_contact, 4 * sizeof(std::uint32_t));
            s.beyond += (o.flags & MODALRT_HIP_BEYOND_VALIDITY) != 0;
          }
      }
  }
} // namespace test
