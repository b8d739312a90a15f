// No step of the kernel's own (DESIGN.md, "Rules of the real-time kernel"; modalrt.h): every change of
// force the kernel makes by itself is rate-limited to force_rate_limit [N per tick]. The cases where
// it stepped, on the lattice, impedance, each a whole scenario whose largest per-tick change of the
// commanded force must stay within the limit (the HIP moves slowly enough that its own changes do too):
//   1. recovery after a fault longer than the hold and the ramp (0.6 s without input mid-press): the
//      force used to come back from 0 to 1.94 N in one tick;
//   2. a HIP dragged sideways until released at release_drag_distance while clamped at 10 N: it used
//      to drop from 10 N to 0 in one tick;
//   3. a new device session (modalrt_kernel_begin_session) mid-press: released, ramped to zero, and
//      no contact until the HIP has been outside the surface;
// and the pull rule: lifting off a press releases the contact before its force pulls (force along
// the outward normal never attractive), while grasp = 1 still pulls up to K x release_distance.
#include "test_support.h"

#include <functional>

using modalrt::LatticeOptions;

namespace
{
  const LatticeOptions lattice;

  double norm(const double f[3]) { return std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]); }

  struct Run
  {
    double        largest_step = 0.0; // [N] largest change of the commanded force between two ticks
    double        most_pull    = 0.0; // [N] most attractive force along the outward normal (>= 0)
    std::uint32_t seen_flags   = 0;   // union of the outputs' flags
    double        last_force[3] = {0.0, 0.0, 0.0};
    bool          started       = false;
    bool          settled       = false; // released and at zero force: steps no longer recorded
  };

  // One impedance tick (or a missing one) recorded into `run`.
  void tick(modalrt_kernel *k, const modalrt_hip_input *in, Run &run, const double normal[3])
  {
    modalrt_hip_output out;
    if (in)
      modalrt_kernel_tick_impedance(k, in, 1, &out);
    else
      modalrt_kernel_tick_missing(k, 1, &out);
    ENSURE(test::finite(out));
    if (run.started && !run.settled)
      {
        const double d[3] = {out.force[0] - run.last_force[0], out.force[1] - run.last_force[1],
                             out.force[2] - run.last_force[2]};
        run.largest_step = std::max(run.largest_step, std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
      }
    const double along = out.force[0] * normal[0] + out.force[1] * normal[1] + out.force[2] * normal[2];
    run.most_pull = std::max(run.most_pull, -along);
    run.started   = true;
    run.seen_flags |= out.flags;
    std::copy_n(out.force, 3, run.last_force);
    // Released and ramped to zero: what follows (the freed part swinging back onto a HIP that stayed
    // inside it) is the part's doing, not a change of the kernel's own.
    run.settled = run.settled || ((run.seen_flags & MODALRT_HIP_RELEASED) && norm(out.force) == 0.0);
  }

  struct Scene
  {
    modalrt_basis     *basis = test::load(modalrt::make_lattice_cantilever(lattice));
    modalrt_kernel_def def   = modalrt_kernel_default_def();
    modalrt_kernel    *k     = nullptr;
    std::uint32_t      v     = modalrt::lattice_display_vertex(lattice, 8, 1); // the tip, top face
    const double      *rest  = modalrt_basis_display_vertices(basis) + 3 * v;
    const double       up[3] = {0.0, 0.0, 1.0}; // the top face's outward normal
    modalrt_hip_input  in{};
    Run                run;

    explicit Scene(std::uint32_t grasp = 0)
    {
      def.grasp = grasp;
      k         = test::create(basis, def);
      in        = test::hip_at(rest);
    }
    ~Scene()
    {
      modalrt_kernel_destroy(k);
      modalrt_basis_destroy(basis);
    }
    // The HIP moves from its position to `to` over `ticks` ticks (straight, minimum jerk: a hand
    // that starts and stops smoothly).
    void move(const double to[3], int ticks)
    {
      const double from[3] = {in.position[0], in.position[1], in.position[2]};
      const double duration = ticks * def.time_step;
      for (int n = 1; n <= ticks; ++n)
        {
          const double tau = double(n) / ticks, s = tau * tau * tau * (10 - 15 * tau + 6 * tau * tau),
                       ds = 30 * tau * tau * (1 - tau) * (1 - tau) / duration;
          for (int d = 0; d < 3; ++d)
            {
              in.position[d] = from[d] + (to[d] - from[d]) * s;
              in.velocity[d] = (to[d] - from[d]) * ds;
            }
          tick(k, &in, run, up);
        }
      std::fill_n(in.velocity, 3, 0.0);
    }
    void stay(int ticks)
    {
      for (int n = 0; n < ticks; ++n)
        tick(k, &in, run, up);
    }
    // From 3 mm above the vertex down to `depth` below it, slowly (0.01 mm per tick).
    void press(double depth)
    {
      const double above[3] = {rest[0], rest[1], rest[2] + 0.003};
      std::copy_n(above, 3, in.position);
      stay(10);
      const double below[3] = {rest[0], rest[1], rest[2] - depth};
      move(below, int((0.003 + depth) / 1e-5));
      stay(300);
    }
    double force_now() const { return norm(run.last_force); }
  };

  void recovery_after_fault()
  {
    Scene s;
    s.press(0.002);
    const double pressed = s.force_now();
    for (int n = 0; n < 600; ++n) // 0.6 s without input: held 0.5 s, ramped to 0 by 0.55 s
      tick(s.k, nullptr, s.run, s.up);
    ENSURE(s.force_now() == 0.0);
    Run after;
    after.started = true;
    std::copy_n(s.run.last_force, 3, after.last_force);
    s.run.seen_flags = 0;
    for (int n = 0; n < 200; ++n)
      tick(s.k, &s.in, after, s.up);
    s.run.largest_step = std::max(s.run.largest_step, after.largest_step);
    const double limit = s.def.force_rate_limit;
    ENSURE(pressed > 0.5);
    ENSURE(after.seen_flags & MODALRT_HIP_FORCE_RAMPING);
    ENSURE(s.run.largest_step <= limit * (1.0 + 1e-12));
    ENSURE_NEAR(norm(after.last_force), pressed, 0.05 * pressed); // back
    std::printf("  recovery after 0.6 s without input: %.3f N back from 0, largest step %.4f N (limit %.2f N "
                "per tick)\n", pressed, s.run.largest_step, limit);
  }

  void release_by_drag()
  {
    Scene s;
    s.press(0.002);
    const double side[3] = {s.rest[0] - 0.03, s.rest[1], s.rest[2] - 0.002};
    s.move(side, 400); // at most 0.14 mm per tick: the coupling's force grows by up to 0.14 N per tick
    const double limit = s.def.force_rate_limit;
    ENSURE(s.run.seen_flags & MODALRT_HIP_FORCE_CLAMPED);
    ENSURE(s.run.seen_flags & MODALRT_HIP_RELEASED);
    ENSURE(s.run.seen_flags & MODALRT_HIP_FORCE_RAMPING);
    ENSURE(s.run.settled);
    ENSURE(s.run.largest_step <= limit * (1.0 + 1e-12));
    std::printf("  dragged 3 cm sideways at 2 mm depth: clamped at %.0f N, released, largest step %.4f N\n",
                s.def.device.max_force, s.run.largest_step);
  }

  void new_session_mid_press()
  {
    Scene s;
    s.press(0.002);
    const double pressed = s.force_now();
    ENSURE(modalrt_kernel_begin_session(s.k) == MODALRT_OK);
    modalrt_hip_output out;
    modalrt_kernel_tick_impedance(s.k, &s.in, 1, &out);
    ENSURE(out.in_contact == 0 && (out.flags & MODALRT_HIP_FORCE_RAMPING));
    ENSURE(norm(out.force) >= pressed - s.def.force_rate_limit * (1.0 + 1e-12));
    std::copy_n(out.force, 3, s.run.last_force);
    s.run.seen_flags = 0;
    s.stay(200); // still inside the part: no contact until the HIP has left the surface
    ENSURE(s.force_now() == 0.0 && !(s.run.seen_flags & MODALRT_HIP_CONTACT_STARTED));
    ENSURE(s.run.largest_step <= s.def.force_rate_limit * (1.0 + 1e-12));
    s.press(0.002);
    ENSURE(s.run.seen_flags & MODALRT_HIP_CONTACT_STARTED);
    std::printf("  new session mid-press: %.3f N ramped to 0, no contact until the HIP came out and in again\n",
                pressed);
  }

  // Lifting off a 2 mm press at 0.02 mm per tick. Returns the most attractive force seen.
  double lift_off(std::uint32_t grasp)
  {
    Scene s(grasp);
    s.press(0.002);
    const double up[3] = {s.rest[0], s.rest[1], s.rest[2] + 0.005};
    s.move(up, 350);
    ENSURE(s.run.seen_flags & MODALRT_HIP_RELEASED);
    ENSURE(s.run.largest_step <= s.def.force_rate_limit * (1.0 + 1e-12));
    return s.run.most_pull;
  }
} // namespace

int main()
{
  recovery_after_fault();
  release_by_drag();
  new_session_mid_press();
  const double pull = lift_off(0), grasp_pull = lift_off(1);
  ENSURE(pull <= 1e-12);
  ENSURE(grasp_pull > 0.5); // grasp: pulls up to K x release_distance = 1 N before it lets go
  std::printf("  lift-off: most attractive force %.3g N (grasp = 1: %.3f N)\n", pull, grasp_pull);

  modalrt_basis     *basis = test::load(modalrt::make_lattice_cantilever(lattice));
  modalrt_kernel_def def   = modalrt_kernel_default_def();
  modalrt_kernel    *bad   = nullptr;
  def.force_rate_limit     = 0.0;
  ENSURE(modalrt_kernel_create(basis, &def, &bad) == MODALRT_ERROR_INVALID_ARGUMENT && !bad);
  ENSURE(std::string(modalrt_last_error_message()).find("force_rate_limit") != std::string::npos);
  def           = modalrt_kernel_default_def();
  def.grasp     = 2;
  ENSURE(modalrt_kernel_create(basis, &def, &bad) == MODALRT_ERROR_INVALID_ARGUMENT && !bad);
  modalrt_basis_destroy(basis);
  return test::finish("test_force_steps");
}
