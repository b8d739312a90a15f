// Impedance step: the virtual coupling's checks against the device, its steady state against the
// full static compliance (one and two HIPs), force clamping, and stability of a stiff coupling on
// a compliant part.
#include "test_support.h"

#include <string>

using modalrt::BasisContent;
using modalrt::LatticeOptions;

namespace
{
  LatticeOptions soft_lattice()
  {
    LatticeOptions o;
    o.all_candidates    = true;
    o.stiffness_modulus = 2e6; // a soft part: the coupling spring is stiffer than the part
    return o;
  }

  // Full static compliance between candidate vertices va and vb of a space: B_a Lambda^-1 B_b^T + C_ab.
  void full_compliance(const BasisContent &c, std::uint32_t s, std::uint32_t va, std::uint32_t vb, double C[9])
  {
    const auto       &sp = c.spaces[s];
    const std::size_t a = std::lower_bound(sp.candidates.begin(), sp.candidates.end(), va) - sp.candidates.begin();
    const std::size_t b = std::lower_bound(sp.candidates.begin(), sp.candidates.end(), vb) - sp.candidates.begin();
    const auto        G = modalrt::content_static_compliance(sp, a, b);
    std::copy(G.begin(), G.end(), C);
  }

  // Solves the small dense system A x = y (Gaussian elimination, n <= 12).
  std::vector<double> solve(std::vector<double> A, std::vector<double> y)
  {
    const std::size_t n = y.size();
    for (std::size_t k = 0; k < n; ++k)
      {
        std::size_t p = k;
        for (std::size_t i = k + 1; i < n; ++i)
          if (std::fabs(A[i * n + k]) > std::fabs(A[p * n + k]))
            p = i;
        for (std::size_t j = 0; j < n; ++j)
          std::swap(A[k * n + j], A[p * n + j]);
        std::swap(y[k], y[p]);
        for (std::size_t i = k + 1; i < n; ++i)
          {
            const double f = A[i * n + k] / A[k * n + k];
            for (std::size_t j = k; j < n; ++j)
              A[i * n + j] -= f * A[k * n + j];
            y[i] -= f * y[k];
          }
      }
    for (std::size_t k = n; k-- > 0;)
      {
        for (std::size_t j = k + 1; j < n; ++j)
          y[k] -= A[k * n + j] * y[j];
        y[k] /= A[k * n + k];
      }
    return y;
  }

  void device_limits()
  {
    modalrt_basis *b = test::load(modalrt::make_lattice_cantilever());
    struct Case
    {
      double      K, D, physical;
      std::uint32_t passivity_control;
      int         status;
      const char *text;
    } cases[] = {{4000, 2, 0, 1, MODALRT_ERROR_DEVICE_LIMIT, "max_stiffness"},
                 {1000, 20, 0, 1, MODALRT_ERROR_DEVICE_LIMIT, "max_damping"},
                 // Colgate & Schenkel at T = 1 ms: b > K T / 2 + |B|. The former check, K T / 2 < b + D,
                 // let the default coupling (1000 N/m, 2 N s/m) through with b = 0.
                 {1000, 2, 0, 0, MODALRT_ERROR_DEVICE_LIMIT, "not passive"},
                 {3000, 1, 1, 0, MODALRT_ERROR_DEVICE_LIMIT, "not passive"},
                 {1000, 2, 2.5, 0, MODALRT_ERROR_DEVICE_LIMIT, "K T / 2 + |B| = 2.5"}, // at the boundary
                 {1000, 2, 2.5 * (1 + 1e-12), 0, MODALRT_OK, ""},                     // just above it
                 {3000, 1, 2.5 * (1 + 1e-12), 0, MODALRT_OK, ""},
                 {1000, 2, 0, 1, MODALRT_OK, ""}}; // refused by the condition, run with the controller
    for (const Case &c : cases)
      {
        modalrt_kernel_def def      = modalrt_kernel_default_def();
        def.coupling_stiffness      = c.K;
        def.coupling_damping        = c.D;
        def.device.physical_damping = c.physical;
        def.passivity_control       = c.passivity_control;
        modalrt_kernel *k           = nullptr;
        const int       status      = modalrt_kernel_create(b, &def, &k);
        ENSURE(status == c.status && (status == MODALRT_OK) == (k != nullptr));
        ENSURE(std::string(modalrt_last_error_message()).find(c.text) != std::string::npos);
        if (status != MODALRT_OK)
          std::printf("  refused as expected: %s\n", modalrt_last_error_message());
        modalrt_kernel_destroy(k);
      }
    modalrt_basis_destroy(b);
  }

  // A HIP held at a fixed point inside the part: the coupling force converges to the static
  // solution of (I + K C) F = K (x_hip - x_rest), C the full compliance of the active vertices.
  // sparse: the cross compliance in version 1.1's rows (test::load writes and reads it back).
  void steady_state(std::uint32_t hips, bool sparse)
  {
    const LatticeOptions o = soft_lattice();
    const BasisContent   c = modalrt::make_lattice_cantilever(o);
    modalrt_basis       *b = test::load(sparse ? modalrt::with_sparse_cross(c) : c);
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.hip_capacity       = hips;
    def.switch_rule        = MODALRT_SWITCH_NEVER; // stay in the global space (fewest modes, largest correction)
    def.grasp              = 1; // the coupling's steady state: the soft part's first swing must not release it
    modalrt_kernel *k      = test::create(b, def);

    const std::uint32_t vertices[2] = {modalrt::lattice_display_vertex(o, 7, 1), modalrt::lattice_display_vertex(o, 5, 2)};
    const double        offsets[2][3] = {{0.0005, -0.0003, -0.002}, {-0.0002, 0.0004, -0.001}};
    std::vector<modalrt_hip_input> in(hips);
    std::vector<double>            dx;
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        in[h] = test::hip_at(modalrt_basis_display_vertices(b) + 3 * vertices[h]);
        for (int d = 0; d < 3; ++d)
          {
            in[h].position[d] += offsets[h][d];
            dx.push_back(def.coupling_stiffness * offsets[h][d]);
          }
        ENSURE(modalrt_kernel_contact_begin(k, h, vertices[h]) == MODALRT_OK);
      }
    std::vector<modalrt_hip_output> out(hips);
    for (int n = 0; n < 20000; ++n)
      modalrt_kernel_tick_impedance(k, in.data(), hips, out.data());

    const std::size_t   n3 = 3 * hips;
    std::vector<double> A(n3 * n3, 0.0);
    for (std::uint32_t a = 0; a < hips; ++a)
      for (std::uint32_t bb = 0; bb < hips; ++bb)
        {
          double C[9];
          full_compliance(c, 0, vertices[a], vertices[bb], C);
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
              A[(3 * a + i) * n3 + 3 * bb + j] = (a == bb && i == j ? 1.0 : 0.0) + def.coupling_stiffness * C[3 * i + j];
        }
    const std::vector<double> F = solve(A, dx);
    double                    scale = 0.0;
    for (double f : F)
      scale = std::max(scale, std::fabs(f));
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        ENSURE(out[h].in_contact == 1 && (out[h].flags & MODALRT_HIP_CORRECTED));
        for (int d = 0; d < 3; ++d)
          ENSURE_NEAR(out[h].force[d], -F[3 * h + d], 1e-9 * scale); // the device feels the reaction
      }
    std::printf("  %u HIP(s): steady coupling force on the part [%.6f %.6f %.6f] N\n", hips, F[0], F[1], F[2]);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  void force_clamped()
  {
    modalrt_basis     *b   = test::load(modalrt::make_lattice_cantilever());
    modalrt_kernel_def def = modalrt_kernel_default_def();
    modalrt_kernel    *k   = test::create(b, def);
    const std::uint32_t v  = 13;
    modalrt_hip_input   in = test::hip_at(modalrt_basis_display_vertices(b) + 3 * v);
    in.position[2] -= 0.05; // 5 cm deep: K dx = 50 N
    modalrt_hip_output out;
    modalrt_kernel_contact_begin(k, 0, v);
    for (int tick = 0; tick < 60; ++tick) // the contact's force starts at force_rate_limit per tick
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    const double size = std::sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
    ENSURE_NEAR(size, def.device.max_force, 1e-12);
    ENSURE(out.flags & MODALRT_HIP_FORCE_CLAMPED);
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    ENSURE(stats.clamped_forces >= 1 && stats.clamped_forces <= 60);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // The stiffest coupling the device allows on a soft part, HIP moving fast in and out: forces stay
  // within the device limit, and once the HIP stops the part comes to rest (no sustained oscillation).
  void stiff_coupling_is_stable()
  {
    const LatticeOptions o = soft_lattice();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.coupling_stiffness = def.device.max_stiffness;
    def.coupling_damping   = 2.0;
    def.auto_release       = 0;
    modalrt_kernel *k      = test::create(b, def);
    const std::uint32_t v  = modalrt::lattice_display_vertex(o, 8, 1);
    const double       *x0 = modalrt_basis_display_vertices(b) + 3 * v;
    modalrt_kernel_contact_begin(k, 0, v);
    modalrt_hip_input  in = test::hip_at(x0);
    modalrt_hip_output out;
    double             worst = 0.0;
    for (int n = 0; n < 4000; ++n)
      {
        const double t = n * def.time_step;
        in.position[2] = x0[2] - 0.002 * (1 - std::cos(2 * 3.14159265358979 * 5 * t));
        in.velocity[2] = -0.002 * 2 * 3.14159265358979 * 5 * std::sin(2 * 3.14159265358979 * 5 * t);
        modalrt_kernel_tick_impedance(k, &in, 1, &out);
        worst = std::max(worst, std::fabs(out.force[2]));
      }
    ENSURE(std::isfinite(worst) && worst <= def.device.max_force * (1 + 1e-12));
    in.velocity[2] = 0.0;
    for (int n = 0; n < 20000; ++n)
      modalrt_kernel_tick_impedance(k, &in, 1, &out);
    std::vector<double> q(64), q_dot(64);
    std::uint32_t       r = 0;
    modalrt_kernel_get_modal_state(k, q.data(), q_dot.data(), 64, &r);
    double speed = 0.0;
    for (std::uint32_t i = 0; i < r; ++i)
      speed = std::max(speed, std::fabs(q_dot[i]));
    ENSURE(speed < 1e-9);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  device_limits();
  steady_state(1, false);
  steady_state(2, false);
  steady_state(2, true);
  force_clamped();
  stiff_coupling_is_stable();
  return test::finish("test_coupling");
}
