// Contact: snap to the closest vertex, release rules, switch of modal space (with and without the
// transfer, measuring the jump), two HIPs in one VOI and in two VOIs. The lattice cantilever's
// spaces have different numbers of modes but exact static corrections, so the felt static response
// at candidates equals the full model's in every space: the cross terms are checked against that.
#include "test_support.h"

using modalrt::BasisContent;
using modalrt::LatticeOptions;

namespace
{
  const LatticeOptions lattice; // 9 x 3 top-face vertices, spaces 0 (global, r = 8) and 1 (tip, r = 16)

  std::uint32_t vertex(std::uint32_t i, std::uint32_t j) { return modalrt::lattice_display_vertex(lattice, i, j); }

  const double *rest(const modalrt_basis *b, std::uint32_t v) { return modalrt_basis_display_vertices(b) + 3 * v; }

  // A HIP `height` above (or below, negative) vertex v along +z (the top face's normal).
  modalrt_hip_input above(const modalrt_basis *b, std::uint32_t v, double height)
  {
    modalrt_hip_input in = test::hip_at(rest(b, v));
    in.position[2] += height;
    return in;
  }

  modalrt_kernel_def admittance_def()
  {
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.hip_capacity       = 2;
    return def;
  }

  void snap_and_release_admittance()
  {
    modalrt_basis     *b = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel    *k = test::create(b, admittance_def());
    modalrt_hip_output out{};
    const std::uint32_t v = vertex(6, 1); // in the tip VOI

    modalrt_hip_input in = above(b, v, 0.005);
    in.position[0] += 0.004; // off the vertex: the closest one is still v
    ENSURE(modalrt_kernel_tick_admittance(k, &in, 1, &out) == MODALRT_OK);
    ENSURE(out.in_contact == 0 && out.active_vertex == MODALRT_NONE && out.space == 0);
    ENSURE(test::distance(out.position, in.position) == 0.0);

    in.position[2] = rest(b, v)[2] - 1e-4; // touches
    ENSURE(modalrt_kernel_tick_admittance(k, &in, 1, &out) == MODALRT_OK);
    ENSURE(out.in_contact == 1 && out.active_vertex == v);
    ENSURE((out.flags & MODALRT_HIP_CONTACT_STARTED) && (out.flags & MODALRT_HIP_SPACE_SWITCHED));
    ENSURE(out.space == 1 && (out.flags & MODALRT_HIP_CORRECTED));

    // Pushing down: the felt position sinks and stays on the part.
    in.force[2] = -1.0;
    for (int n = 0; n < 200; ++n)
      modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.position[2] < rest(b, v)[2]);
    ENSURE(out.force[2] == -1.0);

    // Pulling up releases; the HIP does not snap again before it has left the surface.
    in.force[2] = +0.1;
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 0 && (out.flags & MODALRT_HIP_RELEASED));
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 0);
    in.position[2] = rest(b, v)[2] + 0.003; // out by more than release_distance: re-armed
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    in.position[2] = rest(b, v)[2] - 0.001;
    in.force[2]    = 0.0;
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.active_vertex == v);

    // Explicit release.
    ENSURE(modalrt_kernel_release_hip(k, 0) == MODALRT_OK);
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 0);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  void snap_to_the_deformed_surface()
  {
    // The tip is pushed down at one vertex. A second HIP between the rest and the deformed position
    // of the neighbouring vertex is inside the part at rest but outside the deformed part: it must
    // not snap. Below the deformed position it snaps.
    modalrt_basis      *b = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel     *k = test::create(b, admittance_def());
    const std::uint32_t pushed = vertex(8, 1), probe = vertex(8, 0);
    ENSURE(modalrt_kernel_contact_begin(k, 0, pushed) == MODALRT_OK);
    modalrt_hip_input in[2] = {above(b, pushed, 0.0), above(b, probe, 0.0)};
    in[0].force[2]          = -2.0;
    ENSURE(modalrt_kernel_settle(k, in, 1) == MODALRT_OK);
    modalrt_hip_output out[2];
    modalrt_kernel_tick_admittance(k, in, 1, out);

    modalrt_snapshot *snapshot = nullptr;
    modalrt_snapshot_create(k, &snapshot);
    ENSURE(modalrt_kernel_snapshot_read(k, snapshot) == 1);
    double u[3];
    modalrt_display_reconstruct_f64(snapshot, probe, probe + 1, MODALRT_DISPLAY_DISPLACEMENTS, u);
    std::printf("  probe vertex sank by %.3e m under 2 N at its neighbour\n", -u[2]);
    ENSURE(u[2] < -1e-4);

    in[1].position[2] = rest(b, probe)[2] + 0.5 * u[2];
    modalrt_kernel_tick_admittance(k, in, 2, out);
    ENSURE(out[1].in_contact == 0);
    in[1].position[2] = rest(b, probe)[2] + 1.5 * u[2];
    modalrt_kernel_tick_admittance(k, in, 2, out);
    ENSURE(out[1].in_contact == 1 && out[1].active_vertex == probe);
    modalrt_snapshot_destroy(snapshot);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // Impedance release. By default a contact whose force would pull is released at once (a HIP 0.5 mm
  // above the surface); with grasp = 1 it holds on, pulling, until the HIP is beyond release_distance.
  // The force of a released HIP ramps to zero at force_rate_limit (no step of the kernel's own).
  void release_impedance(std::uint32_t grasp)
  {
    modalrt_basis *b = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.grasp              = grasp;
    modalrt_kernel    *k   = test::create(b, def);
    const std::uint32_t v  = vertex(4, 1);
    modalrt_hip_input   in = above(b, v, -0.002);
    modalrt_hip_output  out;
    modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.active_vertex == v && out.force[2] > 0.0); // pushed back out
    const double pushed = out.force[2];
    in.position[2] = rest(b, v)[2] + 0.0005; // above the surface, within release_distance
    modalrt_kernel_tick_impedance(k, &in, 1, &out);
    if (grasp)
      {
        for (int n = 0; n < 50; ++n)
          modalrt_kernel_tick_impedance(k, &in, 1, &out);
        ENSURE(out.in_contact == 1 && out.force[2] < 0.0); // kept, pulled into the part
        in.position[2] = rest(b, v)[2] + 0.002; // beyond: released
        modalrt_kernel_tick_impedance(k, &in, 1, &out);
      }
    ENSURE(out.in_contact == 0 && (out.flags & MODALRT_HIP_RELEASED));
    ENSURE(std::fabs(out.force[2]) <= std::fabs(pushed) + def.force_rate_limit);
    for (int n = 0; n < 60; ++n)
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 0 && out.force[2] == 0.0);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // Release that follows the hand: a HIP dragged sideways while pressing stays in contact within
  // release_drag_distance (the coupling pulls the contact along), and is released beyond it, however
  // far (2 cm, or 1 m: a hand flung away); pressing deeper never releases.
  void release_by_drag(double drag)
  {
    modalrt_basis     *b   = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel_def def = modalrt_kernel_default_def();
    modalrt_kernel    *k   = test::create(b, def);
    const std::uint32_t v  = vertex(4, 1);
    modalrt_hip_input   in = above(b, v, -0.002);
    modalrt_hip_output  out;
    for (int n = 0; n < 20; ++n)
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.active_vertex == v);
    in.position[2] = rest(b, v)[2] - 0.05; // 5 cm deep: clamped, never released
    for (int n = 0; n < 20; ++n)
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && (out.flags & MODALRT_HIP_FORCE_CLAMPED));
    in.position[2] = rest(b, v)[2] - 0.002;
    in.position[0] += 0.5 * def.release_drag_distance; // half the distance sideways: kept, pulled along
    for (int n = 0; n < 20; ++n)
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.force[0] < 0.0); // the device is pulled back towards the contact
    in.position[0] = rest(b, v)[0] + drag;
    modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.in_contact == 0 && (out.flags & MODALRT_HIP_RELEASED) && (out.flags & MODALRT_HIP_FORCE_RAMPING));
    for (int n = 0; n < 60; ++n) // the force ramps to zero at force_rate_limit: 10 N in 50 ticks
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    ENSURE(out.force[0] == 0.0 && out.force[1] == 0.0 && out.force[2] == 0.0);
    std::printf("  dragged %g m sideways at 2 mm depth: released (release_drag_distance %g m)\n", drag,
                def.release_drag_distance);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // The tip is bent in the tip space, then a contact starts in the global region: the kernel
  // switches to the global space. With the transfer, the active vertex barely moves; without, the
  // modal state restarts at rest and the vertex jumps back by its whole displacement.
  double switch_jump(bool carry)
  {
    modalrt_basis     *b   = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel_def def = admittance_def();
    def.carry_state_on_switch = carry ? 1 : 0;
    modalrt_kernel *k         = test::create(b, def);
    const std::uint32_t tip = vertex(8, 1), root_side = vertex(3, 1);
    ENSURE(modalrt_kernel_contact_begin(k, 0, tip) == MODALRT_OK);
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    ENSURE(stats.active_space == 1 && stats.switch_count == 1);
    modalrt_hip_input in = above(b, tip, 0.0);
    in.force[2]          = -1.0;
    modalrt_kernel_settle(k, &in, 1);
    modalrt_kernel_release_hip(k, 0);
    const double jump_before = stats.max_switch_jump;
    ENSURE(modalrt_kernel_contact_begin(k, 1, root_side) == MODALRT_OK);
    modalrt_kernel_get_stats(k, &stats);
    ENSURE(stats.active_space == 0 && stats.switch_count == 2);
    ENSURE(jump_before == 0.0);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
    return stats.max_switch_jump;
  }

  void switch_with_and_without_transfer()
  {
    const double with = switch_jump(true), without = switch_jump(false);
    std::printf("  switch jump at the new active vertex: %.3e m with the transfer, %.3e m without\n", with, without);
    ENSURE(without > 1e-5);
    ENSURE(with < 0.01 * without);
  }

  // Felt static displacements of HIPs at `vertices` under `forces` in a kernel that stays in `space`.
  std::vector<double> felt_static(const modalrt_basis *b, std::uint32_t space, const std::vector<std::uint32_t> &vertices,
                                  const std::vector<double> &forces, std::uint32_t *reached_space = nullptr,
                                  bool automatic = false)
  {
    modalrt_kernel_def def = admittance_def();
    def.initial_space      = space;
    def.switch_rule        = automatic ? MODALRT_SWITCH_AT_CONTACT_START : MODALRT_SWITCH_NEVER;
    def.auto_release       = 0;
    modalrt_kernel *k      = test::create(b, def);
    std::vector<modalrt_hip_input> in;
    for (std::size_t h = 0; h < vertices.size(); ++h)
      {
        modalrt_kernel_contact_begin(k, std::uint32_t(h), vertices[h]);
        in.push_back(test::hip_at(rest(b, vertices[h]), forces[3 * h], forces[3 * h + 1], forces[3 * h + 2]));
      }
    modalrt_kernel_settle(k, in.data(), std::uint32_t(in.size()));
    std::vector<modalrt_hip_output> out(in.size());
    modalrt_kernel_tick_admittance(k, in.data(), std::uint32_t(in.size()), out.data());
    std::vector<double> u;
    for (std::size_t h = 0; h < vertices.size(); ++h)
      for (int d = 0; d < 3; ++d)
        u.push_back(out[h].position[d] - in[h].position[d]);
    if (reached_space)
      *reached_space = out[0].space;
    modalrt_kernel_destroy(k);
    return u;
  }

  void two_hips()
  {
    LatticeOptions options  = lattice;
    options.all_candidates  = true; // exact static correction at every vertex of both spaces
    options.patch_radius    = 0.03; // patches of several vertices
    modalrt_basis *b        = test::load(modalrt::make_lattice_cantilever(options));
    const std::vector<double> forces = {0.3, -0.2, -1.0, -0.1, 0.4, -0.5};

    // Two HIPs in the tip VOI: the automatic switch picks the tip space; its felt response (8 more
    // modes, smaller residual) equals the global space's, cross terms included.
    std::uint32_t space = 99;
    const std::vector<std::uint32_t> in_voi = {vertex(6, 0), vertex(8, 2)};
    const auto tip    = felt_static(b, 0, in_voi, forces, &space, true);
    const auto global = felt_static(b, 0, in_voi, forces);
    ENSURE(space == 1);
    for (int k = 0; k < 6; ++k)
      ENSURE_NEAR(tip[k], global[k], 1e-9 * std::fabs(global[2]));

    // Two HIPs in two regions: the global space.
    const std::vector<std::uint32_t> apart = {vertex(7, 1), vertex(2, 1)};
    const auto automatic = felt_static(b, 0, apart, forces, &space, true);
    const auto in_tip    = felt_static(b, 1, apart, forces);
    ENSURE(space == 0);
    for (int k = 0; k < 6; ++k)
      ENSURE_NEAR(automatic[k], in_tip[k], 1e-9 * std::fabs(in_tip[2]));

    // The second HIP changes what the first feels (the cross terms are there).
    const auto alone = felt_static(b, 0, {apart[0]}, {forces[0], forces[1], forces[2]});
    ENSURE(std::fabs(alone[2] - automatic[2]) > 1e-3 * std::fabs(automatic[2]));
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  snap_and_release_admittance();
  snap_to_the_deformed_surface();
  release_impedance(0);
  release_impedance(1);
  release_by_drag(0.02); // the contact point follows the pull by a few mm on this soft lattice
  release_by_drag(1.0);
  switch_with_and_without_transfer();
  two_hips();
  return test::finish("test_contact");
}
