// The haptic loop. Everything a tick touches is allocated by the constructor; the tick functions
// are noexcept and only index into those buffers.
#pragma once

#include "allocator.h"
#include "basis.h"
#include "fail_safe_plane.h"
#include "haptic_mapping.h"
#include "modal_integrator.h"
#include "moving_frame.h"
#include "passivity_controller.h"
#include "proxy_rows.h"
#include "contact_state.h"
#include "proxy_state.h"
#include "snap_search.h"
#include "snapshot.h"

#include <modalrt/modalrt.h>

#include <cstdint>
#include <vector>

namespace modalrt
{
  constexpr std::uint32_t max_hip_capacity = 16;
} // namespace modalrt

struct modalrt_kernel : modalrt::HookAllocated
{
  modalrt_kernel(const modalrt_basis &basis, const modalrt_kernel_def &def);

  // The C API's operations; ticks and the calls documented as tick-thread calls never allocate.
  int  tick(const modalrt_hip_input *inputs, std::uint32_t count, modalrt_hip_output *outputs, bool impedance) noexcept;
  int  tick_missing(std::uint32_t count, modalrt_hip_output *outputs) noexcept;
  int  set_frame(const modalrt_frame_state &state) noexcept;
  int  contact_begin(std::uint32_t hip, std::uint32_t vertex) noexcept;
  int  release(std::uint32_t hip) noexcept;
  void begin_session() noexcept;
  int  switch_space(std::uint32_t space) noexcept;
  int  settle(const modalrt_hip_input *inputs, std::uint32_t count) noexcept;
  void reset() noexcept;

  const modalrt_basis     &basis;
  const modalrt_kernel_def def;
  modalrt_kernel_stats     stats{};
  modalrt::SnapshotExchange snapshots;

  const modalrt::HapticMapping &mapping() const { return mapping_; }
  std::uint32_t active_space() const { return space_; }
  std::uint32_t mode_count() const { return basis.spaces[space_].mode_count; }
  const double *coordinates() const { return q_.data(); }
  const double *velocities() const { return v_.data(); }

private:
  using Contact = modalrt::Contact;

  // The ticks in the part's units; tick() and tick_missing() map the device's units around them and
  // render the result at the hand (hand_rendering.cc).
  int  tick_in_part_units(const modalrt_hip_input *inputs, std::uint32_t count, modalrt_hip_output *outputs,
                          bool impedance) noexcept;
  int  tick_missing_in_part_units(std::uint32_t count, modalrt_hip_output *outputs) noexcept;
  void render_at_hand(const modalrt_hip_input *inputs, std::uint32_t count, modalrt_hip_output *outputs) noexcept;

  // Tick phases, in order.
  std::uint32_t validate(const modalrt_hip_input *inputs, std::uint32_t count, bool impedance) const noexcept;
  void to_body(const modalrt_hip_input *inputs, std::uint32_t count) noexcept
  {
    modalrt::to_body(frame_, inputs, count, body_inputs_.data());
  }
  void          apply_release_rules(std::uint32_t count, bool impedance) noexcept;
  bool          detect_contacts(std::uint32_t count) noexcept;
  void          apply_switch_rule() noexcept;
  void          admittance_step() noexcept;
  void          impedance_step() noexcept;
  void          update_corrections() noexcept;
  void          write_outputs(std::uint32_t count, modalrt_hip_output *outputs, bool impedance) noexcept;
  void          publish_snapshot() noexcept;
  // The fail-safe rule (modalrt.h): the last safe outputs, force held then ramped, flagged; in
  // impedance the force is at most what the fail-safe plane gives the hand at `inputs` (part units;
  // null: unknown).
  int           fail_safe(std::uint32_t count, modalrt_hip_output *outputs,
                          const modalrt_hip_input *inputs = nullptr) noexcept;
  // No step of the kernel's own (modalrt.h): the commanded force of a ramping HIP moves by at most
  // force_rate_limit per tick, towards the coupling's force in contact, towards zero after a release.
  void          limit_contact_force(std::uint32_t hip) noexcept;
  void          ramp_released_force(std::uint32_t hip, double force_world[3]) noexcept;
  void          release_pulling_contacts() noexcept;
  // The validity map (modalrt.h, MODALRT_HIP_BEYOND_VALIDITY): the contact's validity force, the
  // clamp of its force to it (impedance, validity_clamp), the flag of its output.
  double        contact_validity_force(const Contact &contact) const noexcept;
  void          clamp_to_validity(Contact &contact, double F[3]) noexcept;
  bool          beyond_validity(const Contact &contact, const double force[3]) const noexcept;

  // Contacts.
  void begin_contact(std::uint32_t hip, std::uint32_t vertex, const double *offset) noexcept;
  void end_contact(std::uint32_t hip) noexcept;
  void build_row(Contact &contact) noexcept;
  void felt_displacement(const Contact &contact, const double *q, double u[3]) const noexcept;
  void refresh_contact_set() noexcept;
  void refresh_coupling_matrices() noexcept;
  void pair_compliance(const Contact &a, const Contact &b, double C[9]) const noexcept;

  // Proxy contacts (proxy_contact.cc).
  void  begin_proxy(std::uint32_t hip, bool at_hip) noexcept;
  void  slide_proxies(std::uint32_t count) noexcept;
  void  slide_proxy(Contact &contact, const modalrt::BodyInput &in, const double others_u[3],
                    const double others_v[3]) noexcept;
  void  hold_in_friction_cone(Contact &contact, double F[3]) noexcept;
  void  proxy_point(const Contact &contact, double point[3], double normal[3]) const noexcept;
  // What the proxy's rows (proxy_rows.h) and walk (proxy_walk.h) read of the kernel.
  modalrt::ProxyRowView row_view() const noexcept
  {
    return {basis, space_, q_.data(), state_stamp_, integrators_[space_], stored_proxy_rows_};
  }
  void  compose_proxy(Contact &contact, bool reload) noexcept;
  void  proxy_pair_compliance(const Contact &a, const Contact &b, double C[9]) const noexcept;
  void  write_proxy_output(const Contact &contact, modalrt_hip_output &out) const noexcept;
  void  proxy_displacement(Contact &contact, double u[3], double u_dot[3]) noexcept;
  void  observe_passivity(const modalrt_hip_input *inputs, std::uint32_t count) noexcept;
  int   load_vertex_row(std::uint32_t vertex, double *B) const noexcept;

  // Modal state.
  void frame_modal_force(double *f) const noexcept { modalrt::frame_modal_force(frame_, basis.spaces[space_], f); }
  void add_contact_forces(double *f) const noexcept;
  void change_space(std::uint32_t space) noexcept;
  bool solve_coupling(std::uint32_t n) noexcept;

  modalrt::HapticMapping         mapping_;
  modalrt::PassivityController   passivity_;
  modalrt::FailSafePlane         fail_safe_plane_;
  modalrt::Frame                 frame_;
  modalrt::Vector<modalrt::ModalIntegrator> integrators_; // one per space, for def.time_step
  std::uint32_t                  space_ = 0;
  modalrt::Vector<double>            q_, v_, f_, q_free_, v_free_, transfer_scratch_; // max_modes each
  modalrt::Vector<double>            rows_;          // hip_capacity x 3 x max_modes
  modalrt::Vector<Contact>           contacts_;      // hip_capacity
  modalrt::Vector<modalrt::BodyInput> body_inputs_;  // hip_capacity
  modalrt::Vector<std::uint32_t>     flags_;         // hip_capacity, MODALRT_HIP_* of this tick
  modalrt::Vector<modalrt_hip_output> last_outputs_; // hip_capacity: the last safe outputs
  modalrt::Vector<double>            commanded_;     // 3 hip_capacity: the force last commanded on each
                                                     // device [N] world (impedance), where a ramp starts
  modalrt::Vector<std::uint32_t>     ramping_;       // hip_capacity: 1 while a change of the kernel's own
                                                     // is rate-limited (after a fault, after a release)
  modalrt::Vector<std::uint32_t>     active_;        // HIPs in contact, in HIP order
  std::uint32_t                  active_count_ = 0;
  modalrt::Vector<double>            compliance_;    // (3 hip_capacity)^2: C between active contacts
  modalrt::Vector<double>            coupling_;      // (3 hip_capacity)^2: B_a G B_b^T + C_ab
  modalrt::Vector<double>            coupling_velocity_; // (3 hip_capacity)^2: B_a H B_b^T
  modalrt::Vector<double>            system_, rhs_;  // the coupling solve
  modalrt::SnapSearch                snap_search_;
  modalrt::Vector<double>            proxy_rows_;    // hip_capacity x proxy_row_slots x 3 x max_modes
  modalrt::Vector<modalrt::ProxyGram> proxy_grams_;  // hip_capacity x proxy_slot_pairs
  modalrt::StoredProxyRows           stored_proxy_rows_; // sliding contacts only
  modalrt::Vector<double>            observed_positions_; // 3 hip_capacity: the HIPs at the last observed tick [m] world
  std::uint32_t                  observed_count_ = 0; // HIPs observed at the last tick (0: not primed)
  bool                           proxy_region_changed_ = false; // a proxy's nearest vertex changed region
  std::uint64_t                  state_stamp_ = 1; // changes whenever q_ or v_ do (the proxies' cached B q, B v)
  bool                           contacts_changed_ = true;
  bool                           coupling_dirty_   = true;
  bool                           contact_started_  = false;
  std::uint64_t                  ticks_since_publish_ = 0;
  std::uint64_t                  hold_ticks_ = 0, ramp_ticks_ = 2; // the fail-safe rule in ticks
  int                            validity_level_ = 1; // index of def.validity_level among 1, 5, 10 %
};
