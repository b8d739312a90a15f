// Haptic devices behind one small interface, after CHAI3D's cGenericHapticDevice: open/close, a
// spec (cHapticDeviceInfo's max force, stiffness and damping), read the HIPs' state, write the
// force to render (impedance) or the position to track (admittance).
//
// Two devices drive `modal-rt run` without hardware, both from a scripted session:
//   ScriptedProbe  a rigid probe: each HIP is exactly at its scripted target (position and its
//                  velocity), and applies exactly the scripted force. Rendered forces move nothing.
//   SimulatedHand  a spring-damper "hand" per HIP: a mass (the device's end effector and the
//                  finger) pulled towards the scripted target by a critically damped spring, plus
//                  the scripted force. Impedance: the rendered force acts on the mass, so the
//                  contact settles where hand and part balance. Admittance: the device tracks the
//                  part's position in contact, and the hand's pull is the force on the part.
// read_state/write_* run in the haptic thread: no allocation, no I/O.
#pragma once

#include "session.h"

#include <modalrt/modalrt.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace modalrt_tool
{
  struct DeviceSpec
  {
    std::string name;
    double      max_force        = 0.0; // [N]
    double      max_stiffness    = 0.0; // [N/m]
    double      max_damping      = 0.0; // [N s/m]
    double      physical_damping = 0.0; // [N s/m] the device's own viscous damping
  };

  // What a device that picks its contacts itself asks of one HIP this tick (the view's mouse
  // clicks a vertex: contact there now, as a session's `press` event; or the HIP let go).
  struct ContactRequest
  {
    enum Kind
    {
      none,
      press,  // modalrt_kernel_contact_begin at `vertex`
      release // modalrt_kernel_release_hip
    };
    Kind          kind   = none;
    std::uint32_t vertex = 0;
  };

  class Device
  {
  public:
    virtual ~Device() = default;

    // false (and a message in `error`) if the device cannot be used.
    virtual bool              open(std::string &error) = 0;
    virtual void              close()                  = 0;
    virtual const DeviceSpec &spec() const             = 0;
    virtual std::uint32_t     hip_count() const        = 0;

    // Every HIP's state at session time t [s] (non-decreasing between calls): position [m] and
    // velocity [m/s] in the world, the force the user applies [N]. Returns false when the device
    // has no fresh state this tick (a network device whose packet is late): the loop then ticks
    // the kernel with modalrt_kernel_tick_missing (the fail-safe rule) and `inputs` is not used.
    virtual bool read_state(double t, modalrt_hip_input *inputs) = 0;
    // Impedance: the force [N] the device renders on HIP `hip`.
    virtual void write_force(std::uint32_t hip, const double force[3]) = 0;
    // Admittance: the position [m] and velocity [m/s] the device makes HIP `hip` follow while it is
    // in contact (in_contact 0: the HIP moves freely).
    virtual void track_position(std::uint32_t hip, const double position[3], const double velocity[3],
                                bool in_contact) = 0;
    // After a fresh read_state, before the kernel's tick: the contact HIP `hip` asks for. The default
    // asks for none (contacts come from the session's events and the kernel's snap search).
    virtual ContactRequest contact_request(std::uint32_t) { return {}; }
    // The kernel's whole output for HIP `hip` (contact, active vertex, space), every tick, for devices
    // that pass it on; the default ignores it.
    virtual void report_output(std::uint32_t, const modalrt_hip_output &) {}
    // Network devices: true once after the device session changed (a device took the bridge, said
    // HELLO, restarted, left or timed out); the loop then calls modalrt_kernel_begin_session before
    // the tick, so no contact carries over from one session to the next.
    virtual bool take_session_change() { return false; }
    // The design the device asks to feel (two designs, `serve --design-b`): 0 A, 1 B, -1 no request.
    virtual int requested_design() const { return -1; }
    // After the last write of a tick: sends the tick's commands (a network device sends one packet).
    virtual void end_tick() {}
    // The device's own counters (packets, ...), for stats.json; read after the run.
    virtual std::vector<std::pair<std::string, std::uint64_t>> counters() const { return {}; }
  };

  enum class DeviceKind
  {
    hand,
    probe
  };

  // The simulated hand's parameters (one set for every HIP).
  struct HandParameters
  {
    double mass      = 0.1;   // [kg] end effector and finger
    double stiffness = 300.0; // [N/m] the pull towards the target
    double damping   = 10.954451150103322; // [N s/m] 2 sqrt(k m): critically damped
  };

  std::unique_ptr<Device> make_device(DeviceKind kind, const Session &session, double time_step);

  // The kernel's default device (a desktop impedance device at 1 kHz) under the name `name`.
  DeviceSpec default_device_spec(const char *name);

  // Where a HIP that touches nothing waits: half a metre above the middle of the part (farther than
  // any snap distance from it, well inside the workspace).
  void park_position(const modalrt_basis_info &info, double park[3]);
} // namespace modalrt_tool
