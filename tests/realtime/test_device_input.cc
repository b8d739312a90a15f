// Bad device input: NaN, infinity, absurd forces, far positions, too many HIPs, a broken frame, and
// missing input. Each rejected tick leaves the state where it was, repeats the last safe outputs
// (finite) with the FAIL_SAFE flag and is counted. The fail-safe rule over time: a finite absurd
// input (a position of 1e30 m, a velocity of 101 m/s) and a silent device (tick_missing) hold the
// last safe force for fail_safe_hold, ramp it to zero over fail_safe_ramp without a step, and keep
// it at zero; good input ends the run.
#include "test_support.h"

#include <algorithm>
#include <cstring>
#include <limits>

namespace
{
  struct Run
  {
    modalrt_basis     *basis;
    modalrt_kernel    *kernel;
    modalrt_hip_input  good[2];
    modalrt_hip_output last[2];
  };

  std::vector<double> state(const modalrt_kernel *k)
  {
    std::vector<double> q(64), v(64);
    std::uint32_t       r = 0;
    modalrt_kernel_get_modal_state(k, q.data(), v.data(), 64, &r);
    q.resize(r);
    q.insert(q.end(), v.begin(), v.begin() + r);
    return q;
  }

  // Runs one tick with `inputs`; expects a rejection with `reason` and unchanged state and outputs.
  void expect_rejected(Run &run, const modalrt_hip_input *inputs, std::uint32_t count, std::uint32_t reason, bool impedance)
  {
    const std::vector<double> before = state(run.kernel);
    modalrt_kernel_stats      s0, s1;
    modalrt_kernel_get_stats(run.kernel, &s0);
    modalrt_hip_output out[2];
    std::memset(out, 0xFF, sizeof out); // garbage that must be overwritten
    const int status = impedance ? modalrt_kernel_tick_impedance(run.kernel, inputs, count, out)
                                 : modalrt_kernel_tick_admittance(run.kernel, inputs, count, out);
    modalrt_kernel_get_stats(run.kernel, &s1);
    ENSURE(status == MODALRT_INPUT_REJECTED);
    ENSURE(s1.rejected_ticks == s0.rejected_ticks + 1 && (s1.last_reject_reasons & reason));
    ENSURE(state(run.kernel) == before);
    for (std::uint32_t h = 0; h < std::min<std::uint32_t>(count, 2); ++h)
      {
        ENSURE(test::finite(out[h]));
        ENSURE(out[h].flags == MODALRT_HIP_FAIL_SAFE);
        modalrt_hip_output expected = run.last[h];
        expected.flags              = MODALRT_HIP_FAIL_SAFE; // within the hold window: the same force
        ENSURE(std::memcmp(&out[h], &expected, sizeof out[h]) == 0);
      }
  }

  void bad_inputs(bool impedance)
  {
    Run run;
    run.basis             = test::load(modalrt::make_lattice_cantilever());
    modalrt_kernel_def d  = modalrt_kernel_default_def();
    d.hip_capacity        = 2;
    run.kernel            = test::create(run.basis, d);
    const double *x       = modalrt_basis_display_vertices(run.basis);
    run.good[0]           = test::hip_at(x + 3 * 15, 0.0, 0.0, -1.0);
    run.good[1]           = test::hip_at(x + 3 * 21, 0.0, 0.0, -0.5);
    run.good[0].position[2] -= 0.001;
    run.good[1].position[2] -= 0.001;
    for (int n = 0; n < 20; ++n)
      impedance ? modalrt_kernel_tick_impedance(run.kernel, run.good, 2, run.last)
                : modalrt_kernel_tick_admittance(run.kernel, run.good, 2, run.last);
    ENSURE(run.last[0].in_contact == 1 && run.last[1].in_contact == 1);

    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    modalrt_hip_input bad[2] = {run.good[0], run.good[1]};
    bad[1].position[0]       = nan;
    expect_rejected(run, bad, 2, MODALRT_REJECT_NOT_FINITE, impedance);
    bad[1] = run.good[1];
    bad[0].velocity[2] = -inf;
    expect_rejected(run, bad, 2, MODALRT_REJECT_NOT_FINITE, impedance);
    bad[0] = run.good[0];
    bad[0].position[1] = 1e6; // 1000 km away
    expect_rejected(run, bad, 2, MODALRT_REJECT_POSITION, impedance);
    bad[0] = run.good[0];
    bad[0].velocity[0] = 1e4;
    expect_rejected(run, bad, 2, MODALRT_REJECT_VELOCITY, impedance);
    if (!impedance) // forces are inputs of the admittance step only
      {
        bad[0]          = run.good[0];
        bad[0].force[2] = -1e30;
        expect_rejected(run, bad, 2, MODALRT_REJECT_FORCE, impedance);
        bad[0].force[2] = nan;
        expect_rejected(run, bad, 2, MODALRT_REJECT_NOT_FINITE, impedance);
      }
    modalrt_hip_input three[3] = {run.good[0], run.good[1], run.good[1]};
    expect_rejected(run, three, 3, MODALRT_REJECT_HIP_COUNT, impedance);

    // A broken frame is refused and counted; the old frame stays.
    modalrt_frame_state frame = modalrt_frame_state_identity();
    frame.linear_acceleration[2] = nan;
    ENSURE(modalrt_kernel_set_frame(run.kernel, &frame) == MODALRT_ERROR_VALUE);
    ENSURE(std::string(modalrt_last_error_message()).find("modalrt_kernel_set_frame") != std::string::npos);
    frame = modalrt_frame_state_identity();
    frame.angular_acceleration[0] = 1e30;
    ENSURE(modalrt_kernel_set_frame(run.kernel, &frame) == MODALRT_ERROR_VALUE);

    // Good input again: the loop goes on from where it was.
    modalrt_hip_output out[2];
    const int status = impedance ? modalrt_kernel_tick_impedance(run.kernel, run.good, 2, out)
                                 : modalrt_kernel_tick_admittance(run.kernel, run.good, 2, out);
    ENSURE(status == MODALRT_OK && test::finite(out[0]) && test::finite(out[1]) && out[0].in_contact == 1);
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(run.kernel, &stats);
    ENSURE(stats.rejected_ticks == (impedance ? 5u : 7u) && stats.rejected_frames == 2);
    ENSURE(stats.tick_count == 20 + stats.rejected_ticks + 1);
    std::printf("  %s: %llu ticks rejected, %llu frames rejected\n", impedance ? "impedance" : "admittance",
                (unsigned long long)stats.rejected_ticks, (unsigned long long)stats.rejected_frames);
    modalrt_kernel_destroy(run.kernel);
    modalrt_basis_destroy(run.basis);
  }

  // One HIP pressed 2 mm into the lattice's vertex 15 for 50 impedance ticks (the default definition,
  // one HIP): the start of every fail-safe case below.
  struct Pressed
  {
    modalrt_basis     *basis;
    modalrt_kernel_def d;
    modalrt_kernel    *k;
    modalrt_hip_input  good;
    modalrt_hip_output out;
  };

  Pressed press_lattice()
  {
    Pressed p{};
    p.basis          = test::load(modalrt::make_lattice_cantilever());
    p.d              = modalrt_kernel_default_def();
    p.d.hip_capacity = 1;
    p.k              = test::create(p.basis, p.d);
    p.good           = test::hip_at(modalrt_basis_display_vertices(p.basis) + 3 * 15, 0.0, 0.0, 0.0);
    p.good.position[2] -= 0.002;
    for (int n = 0; n < 50; ++n)
      modalrt_kernel_tick_impedance(p.k, &p.good, 1, &p.out);
    return p;
  }

  // The fail-safe rule over time, for one kind of bad input (`kind`: 0 a position of 1e30 m, 1 a
  // velocity of 101 m/s, 2 no input at all) in impedance while pressing.
  void fail_safe_timeline(int kind)
  {
    Pressed             pressed = press_lattice();
    modalrt_basis      *basis   = pressed.basis;
    modalrt_kernel_def  d       = pressed.d;
    modalrt_kernel     *k       = pressed.k;
    modalrt_hip_input   good    = pressed.good;
    modalrt_hip_output  out     = pressed.out;
    const double held = std::sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
    ENSURE(out.in_contact == 1 && held > 0.5);

    modalrt_hip_input bad = good;
    if (kind == 0)
      bad.position[0] = 1e30;
    if (kind == 1)
      bad.velocity[0] = 101.0;
    const int hold_ticks = int(std::lround(d.fail_safe_hold / d.time_step));
    const int ramp_ticks = int(std::lround(d.fail_safe_ramp / d.time_step));
    double    previous   = held, largest_step = 0.0;
    bool      flagged = true, held_exactly = true, monotone = true;
    int       first_zero = -1;
    for (int n = 1; n <= 5000; ++n) // 5 s: "never forever" and never back up
      {
        const int status = kind == 2 ? modalrt_kernel_tick_missing(k, 1, &out) : modalrt_kernel_tick_impedance(k, &bad, 1, &out);
        const double f = std::sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
        flagged        = flagged && status == MODALRT_INPUT_REJECTED && out.flags == MODALRT_HIP_FAIL_SAFE && test::finite(out);
        if (n <= hold_ticks)
          held_exactly = held_exactly && f == held;
        monotone     = monotone && f <= previous;
        largest_step = std::max(largest_step, previous - f);
        if (f == 0.0 && first_zero < 0)
          first_zero = n;
        previous = f;
      }
    ENSURE(flagged && held_exactly && monotone);
    ENSURE(first_zero == hold_ticks + ramp_ticks); // zero exactly when the ramp ends
    ENSURE(previous == 0.0);
    ENSURE(largest_step <= held / ramp_ticks * (1.0 + 1e-9)); // a linear ramp: no step
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    ENSURE(stats.fail_safe_run == 5000 && stats.fail_safe_ticks == 5000);
    ENSURE(stats.dropout_ticks == std::uint64_t(5000 - hold_ticks));
    ENSURE(kind == 2 ? stats.missing_ticks == 5000 && stats.last_reject_reasons == MODALRT_REJECT_MISSING
                     : stats.rejected_ticks == 5000 &&
                         stats.last_reject_reasons == (kind == 0 ? MODALRT_REJECT_POSITION : MODALRT_REJECT_VELOCITY));
    // Good input ends the run: the contact goes on.
    ENSURE(modalrt_kernel_tick_impedance(k, &good, 1, &out) == MODALRT_OK && !(out.flags & MODALRT_HIP_FAIL_SAFE) &&
           out.in_contact == 1);
    modalrt_kernel_get_stats(k, &stats);
    ENSURE(stats.fail_safe_run == 0);
    std::printf("  fail-safe (%s): %.3f N held %d ticks, ramped to 0 over %d ticks, largest step %.4f N\n",
                kind == 0 ? "position 1e30 m" : kind == 1 ? "velocity 101 m/s" : "missing input", held, hold_ticks,
                ramp_ticks, largest_step);
    // A definition without a ramp is refused (a step to zero is not a fail-safe).
    d.fail_safe_ramp       = 0.0;
    modalrt_kernel *no_ramp = nullptr;
    ENSURE(modalrt_kernel_create(basis, &d, &no_ramp) == MODALRT_ERROR_INVALID_ARGUMENT && !no_ramp);
    ENSURE(std::string(modalrt_last_error_message()).find("fail_safe_ramp") != std::string::npos);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(basis);
  }

  // The fail-safe plane (modalrt.h): during a fault the hand is not pushed with the held force
  // whatever it does; the force comes from a plane held where the hand was, across the last safe
  // force F0, at the coupling's stiffness k (no haptic scale). `kind`: 0 the hand withdraws at
  // 20 mm/s behind inputs rejected for their velocity (their positions are trusted); 1 the input
  // stops arriving as the hand withdraws at 20 mm/s (its last velocity carries it on); 2 the hand
  // presses on at 20 mm/s; 3 a trusted input jumps 5 cm out. Withdrawing: F0 (1 - k s / F0), zero
  // long before the hold ends, at most the work F0^2 / (2 k) given to the hand (the hold gave
  // F0 x the distance); pressing on: F0, no more; the jump: down at the rate limit, no step.
  void fail_safe_plane(int kind)
  {
    Pressed             pressed = press_lattice();
    modalrt_basis      *basis   = pressed.basis;
    modalrt_kernel_def  d       = pressed.d;
    modalrt_kernel     *k       = pressed.k;
    modalrt_hip_input   good    = pressed.good;
    modalrt_hip_output  out     = pressed.out;
    const double speed = kind == 2 ? -0.02 : 0.02; // [m/s] along the force: out of the part
    double       along[3], F0[3];
    const double held = std::sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
    for (int i = 0; i < 3; ++i)
      along[i] = out.force[i] / held;
    if (kind == 1) // the last accepted tick knows the hand's velocity
      {
        for (int i = 0; i < 3; ++i)
          good.velocity[i] = speed * along[i];
        modalrt_kernel_tick_impedance(k, &good, 1, &out);
      }
    std::copy_n(out.force, 3, F0);
    const double f0 = std::sqrt(F0[0] * F0[0] + F0[1] * F0[1] + F0[2] * F0[2]);
    ENSURE(out.in_contact == 1 && f0 > 0.5);
    // The hand moves along the force before that tick; the damper may turn F0 a little off it.
    const double aligned   = (along[0] * F0[0] + along[1] * F0[1] + along[2] * F0[2]) / f0;
    const double stiffness = d.coupling_stiffness, rate = d.force_rate_limit;
    const int    hold_ticks = int(std::lround(d.fail_safe_hold / d.time_step));
    double       previous = f0, largest_step = 0.0, work = 0.0, worst_error = 0.0;
    int          first_zero = -1;
    for (int n = 1; n <= hold_ticks; ++n)
      {
        modalrt_hip_input hand = good;
        hand.velocity[0]       = 101.0; // rejected, its position trusted
        const double s         = kind == 3 ? 0.05 : speed * n * d.time_step;
        for (int i = 0; i < 3; ++i)
          hand.position[i] = good.position[i] + s * along[i];
        const int status = kind == 1 ? modalrt_kernel_tick_missing(k, 1, &out) : modalrt_kernel_tick_impedance(k, &hand, 1, &out);
        ENSURE(status == MODALRT_INPUT_REJECTED && (out.flags & MODALRT_HIP_FAIL_SAFE) && test::finite(out));
        const double f = std::sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
        const double expected = kind == 3 ? std::max(0.0, f0 - n * rate)
                                          : f0 * std::clamp(1.0 - stiffness * s * aligned / f0, 0.0, 1.0);
        worst_error  = std::max(worst_error, std::fabs(f - expected));
        largest_step = std::max(largest_step, std::fabs(previous - f));
        if (kind < 2)
          work += f * std::fabs(speed) * d.time_step * aligned; // along the force
        if (f == 0.0 && first_zero < 0)
          first_zero = n;
        previous = f;
      }
    ENSURE(worst_error <= 1e-12 * f0);
    ENSURE(largest_step <= rate * (1.0 + 1e-12));
    if (kind == 2)
      ENSURE(first_zero < 0 && previous == f0);
    else
      ENSURE(first_zero > 0 && first_zero < hold_ticks / 2);
    if (kind < 2)
      ENSURE(work <= f0 * f0 / (2.0 * stiffness));
    const char *what[] = {"withdrawing, inputs rejected", "withdrawing, input missing", "pressing on", "input jumps 5 cm out"};
    std::printf("  fail-safe plane (%s): %.3f N, zero after %d ticks, largest step %.4f N, work on the hand %.3g J "
                "(the hold: %.3g J)\n",
                what[kind], f0, first_zero, largest_step, work, kind < 2 ? f0 * std::fabs(speed) * d.fail_safe_hold : 0.0);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(basis);
  }

  // API misuse fails safely.
  void misuse()
  {
    modalrt_hip_output out;
    ENSURE(modalrt_kernel_tick_admittance(nullptr, nullptr, 0, &out) == MODALRT_ERROR_INVALID_ARGUMENT);
    modalrt_basis *b = test::load(modalrt::make_lattice_cantilever());
    modalrt_kernel *k = test::create(b, modalrt_kernel_default_def());
    ENSURE(modalrt_kernel_tick_impedance(k, nullptr, 1, &out) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_kernel_contact_begin(k, 0, 1000000) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_kernel_contact_begin(k, 9, 0) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_kernel_switch_space(k, 5) == MODALRT_ERROR_INVALID_ARGUMENT);
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.time_step          = std::numeric_limits<double>::quiet_NaN();
    modalrt_kernel *bad    = nullptr;
    ENSURE(modalrt_kernel_create(b, &def, &bad) == MODALRT_ERROR_INVALID_ARGUMENT && bad == nullptr);
    ENSURE(std::string(modalrt_last_error_message()).find("time_step") != std::string::npos);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  bad_inputs(false);
  bad_inputs(true);
  for (int kind = 0; kind < 3; ++kind)
    fail_safe_timeline(kind);
  for (int kind = 0; kind < 4; ++kind)
    fail_safe_plane(kind);
  misuse();
  return test::finish("test_device_input");
}
