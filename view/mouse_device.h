// The browser's mouse as a haptic device of the run loop (`modal-rt view`): two HIPs (the second
// with a modifier key), each pressing a display vertex with a force along its inward normal, or let
// go. The page sends commands ("press HIP VERTEX FORCE_N", "release HIP") on the server thread; the
// haptic thread reads the newest through a wait-free triple buffer. The loop runs in admittance: the
// force is the input; a pressed HIP asks for contact at its vertex (a contact request, as a
// session's `press` event) and sits there; a released HIP waits above the part.
//
// With sliding contacts (`--contact proxy`, `slide` true) the loop runs in impedance, since a proxy
// moves on impedance ticks only, and the mouse is a position device: "slide HIP VERTEX X Y Z FORCE_N"
// puts the HIP under the surface point (X, Y, Z) [m] (the point under the pointer, VERTEX the vertex
// nearest it, whose normal n is the pressing direction) and pushes it in along -n until the force the
// kernel renders along n is FORCE_N: the depth below the surface point is servoed each tick by the
// force error over the coupling stiffness, with a time constant of 0.1 s. The surface point is followed with a
// 30 ms first-order lag, so a pointer that jumps between events moves the HIP smoothly; the HIP's
// velocity is its motion over the tick. The kernel's proxy then slides after it under friction.
#pragma once

#include "devices.h" // realtime/tools
#include "triple_buffer.h"

#include <modalrt/modalrt.h>

#include <cstdint>
#include <string>

namespace modalrt_view
{
  class MouseDevice final : public modalrt_tool::Device
  {
  public:
    static constexpr std::uint32_t hips = 2;

    // `slide`: sliding contacts (impedance, the `slide` command); else admittance presses.
    MouseDevice(const modalrt_basis *basis, bool slide);

    // Server thread: a command from a browser; the reply for it ("ok" or "error: ...").
    std::string command(const std::string &text);

    // Haptic thread (no allocation, no lock).
    bool                              open(std::string &) override { return true; }
    void                              close() override {}
    const modalrt_tool::DeviceSpec   &spec() const override { return spec_; }
    std::uint32_t                     hip_count() const override { return hips; }
    bool                              read_state(double t, modalrt_hip_input *inputs) override;
    modalrt_tool::ContactRequest      contact_request(std::uint32_t hip) override;
    void                              write_force(std::uint32_t, const double[3]) override {} // admittance only
    void track_position(std::uint32_t, const double[3], const double[3], bool) override {} // a mouse follows nothing
    void report_output(std::uint32_t hip, const modalrt_hip_output &output) override { last_[hip] = output; }

  private:
    // What the browser asks of the HIPs (server thread -> haptic thread).
    struct Input
    {
      std::uint32_t pressed[hips]  = {0, 0};
      std::uint32_t vertex[hips]   = {0, 0};
      double        force[hips][3] = {}; // [N] world
      double        point[hips][3] = {}; // [m] slide: the surface point under the pointer
    };

    // slide: the HIP's position this tick, servoed to the pressing force (haptic thread).
    void        slide_state(std::uint32_t hip, double dt, modalrt_hip_input &input);

    std::uint32_t            vertex_count_;
    const double            *vertices_, *normals_;
    double                   park_[3] = {};
    modalrt_tool::DeviceSpec spec_;
    TripleBuffer<Input>      exchange_;
    Input                    requested_;          // server thread's
    Input                    mouse_;              // haptic thread's: this tick's
    modalrt_hip_output       last_[hips] = {};    // haptic thread's: the last tick's outputs
    bool                     slide_;
    double                   stiffness_;          // [N/m] the coupling's (the kernel's default), for the servo
    // slide, haptic thread's: the filtered surface point, the depth below it, the HIP's last position.
    double                   point_[hips][3] = {}, depth_[hips] = {}, position_[hips][3] = {};
    std::uint32_t            was_pressed_[hips] = {};
    double                   last_time_ = -1.0;
  };
} // namespace modalrt_view
