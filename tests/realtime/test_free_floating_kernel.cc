// The kernel on a free-floating part's basis (six rigid-body modes with omega = 0), written by
// modal-precompute (tests/precompute/test_free_floating.py passes its .mrt):
// - the rigid-body modes are stored as lambda = 0, and the static compliance is refused (a free part
//   has none);
// - the self-check passes: in the frame that follows the part's rigid acceleration (inertia relief)
//   the elastic state is static and equals the precompute's full-FE answers;
// - a constant force pushes the part as Newton says: the linear momentum from the modal velocities
//   through the participation factors (Gamma^T v) is F t, and the rigid-body modal velocities are
//   exactly B_R^T F t (the double integrator);
// - once the force stops, the part drifts at constant momentum, the elastic energy never grows, and
//   nothing turns non-finite, from dt = 1e-6 s to dt = 0.1 s, and under 1e6 N.
// Usage: test_free_floating_kernel BASIS.mrt
#include "test_support.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

namespace
{
  constexpr std::uint32_t n_rigid = 6;

  struct Part
  {
    const modalrt_basis *basis = nullptr;
    std::uint32_t        r     = 0;
    const double        *lambda = nullptr;
    std::vector<double>  participation; // r x 6
    std::uint32_t        vertex = 0;      // the first candidate
    std::vector<double>  B;               // its 3 x r block
  };

  // What the checks need beyond the C API's accessors, read from the file's own sections.
  std::vector<double> section_f64(const modalrt_basis *basis, const std::vector<char> &file, const char *name,
                                  std::uint32_t space)
  {
    modalrt_basis_info info{};
    modalrt_basis_get_info(basis, &info);
    for (std::uint32_t k = 0; k < info.section_count; ++k)
      {
        modalrt_section_info s{};
        modalrt_basis_get_section(basis, k, &s);
        if (std::string(s.name) == name && s.space == space && s.scalar_type == 3)
          {
            std::vector<double> values(s.count);
            std::memcpy(values.data(), file.data() + s.offset, s.bytes);
            return values;
          }
      }
    std::fprintf(stderr, "the basis has no float64 section %s of space %u\n", name, space);
    std::exit(1);
  }

  Part read_part(const modalrt_basis *basis, const char *path)
  {
    std::ifstream           in(path, std::ios::binary);
    const std::vector<char> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    Part p;
    p.basis  = basis;
    p.lambda = modalrt_basis_eigenvalues(basis, 0);
    modalrt_space_info space{};
    modalrt_basis_get_space_info(basis, 0, &space);
    p.r = space.mode_count;
    p.participation = section_f64(basis, file, "PARTICIPATION", 0);
    p.vertex        = modalrt_basis_candidates(basis, 0)[0];
    const auto blocks = section_f64(basis, file, "CANDIDATE_MODES", 0);
    p.B.assign(blocks.begin(), blocks.begin() + 3 * p.r);
    return p;
  }

  modalrt_kernel_def free_part_def(double time_step)
  {
    modalrt_kernel_def def     = modalrt_kernel_default_def();
    def.time_step              = time_step;
    def.hip_capacity           = 1;
    def.switch_rule            = MODALRT_SWITCH_NEVER;
    def.auto_release           = 0;
    def.workspace_radius       = 1e9; // the part flies away; the device follows it
    def.max_input_force        = 1e7;
    def.max_input_velocity     = 1e12;
    // The coupling must stay passive at long ticks (K T / 2 < D); admittance does not use it.
    def.coupling_stiffness = std::min(def.coupling_stiffness, def.coupling_damping / time_step);
    return def;
  }

  void check_stored_modes(const Part &p)
  {
    ENSURE(p.r > n_rigid);
    for (std::uint32_t i = 0; i < n_rigid; ++i)
      ENSURE(p.lambda[i] == 0.0);
    ENSURE(p.lambda[n_rigid] > 0.0);
    double G[9];
    ENSURE(modalrt_basis_contact_compliance(p.basis, 0, p.vertex, G, nullptr) == MODALRT_ERROR_VALUE);
  }

  void check_self_check(const Part &p)
  {
    modalrt_verify_report report{};
    ENSURE(modalrt_basis_verify(p.basis, &report) == MODALRT_OK);
    ENSURE(report.case_count > 0);
    std::printf("self-check (inertia relief): %u cases, max relative error %.3g\n", report.case_count,
                report.max_relative_error);
  }

  // Linear momentum and angular momentum about the centre of mass of the modal velocities: Gamma^T v.
  std::array<double, 6> momentum(const Part &p, const std::vector<double> &v)
  {
    std::array<double, 6> m{};
    for (std::uint32_t i = 0; i < p.r; ++i)
      for (int k = 0; k < 6; ++k)
        m[k] += p.participation[6 * i + k] * v[i];
    return m;
  }

  // Pushes the part with F for n ticks, then lets it drift for n ticks.
  void check_push_and_drift(const Part &p, double time_step, double force_scale, std::uint32_t n)
  {
    modalrt_kernel *kernel = test::create(p.basis, free_part_def(time_step));
    ENSURE(modalrt_kernel_contact_begin(kernel, 0, p.vertex) == MODALRT_OK);
    const double *rest = &modalrt_basis_display_vertices(p.basis)[3 * p.vertex];
    modalrt_hip_input  in{};
    modalrt_hip_output out{};
    std::copy_n(rest, 3, in.position);
    const double F[3] = {0.3 * force_scale, -0.5 * force_scale, 0.8 * force_scale};
    std::copy_n(F, 3, in.force);
    std::vector<double> q(p.r), v(p.r);
    bool finite = true;
    for (std::uint32_t t = 0; t < n; ++t)
      {
        ENSURE(modalrt_kernel_tick_admittance(kernel, &in, 1, &out) == MODALRT_OK);
        std::copy_n(out.position, 3, in.position); // the device follows the part
        for (double x : out.position)
          finite = finite && std::isfinite(x);
      }
    modalrt_kernel_get_modal_state(kernel, q.data(), v.data(), p.r, nullptr);
    const double duration = n * time_step;

    // The rigid-body modal velocities: exactly B_R^T F t (modal forces of the rigid modes).
    double worst_rigid = 0., size = 0.;
    for (std::uint32_t i = 0; i < n_rigid; ++i)
      {
        const double expected = (p.B[i] * F[0] + p.B[p.r + i] * F[1] + p.B[2 * p.r + i] * F[2]) * duration;
        worst_rigid = std::max(worst_rigid, std::fabs(v[i] - expected));
        size        = std::max(size, std::fabs(expected));
      }
    ENSURE(worst_rigid <= 1e-10 * size);

    // Momentum F t, from the participation factors (independent of B).
    const auto m = momentum(p, v);
    for (int k = 0; k < 3; ++k)
      ENSURE_NEAR(m[k], F[k] * duration, 1e-8 * force_scale * duration);
    std::printf("dt %g s, |F| %g N, %u ticks: momentum (%.6g, %.6g, %.6g) N s vs F t (%.6g, %.6g, %.6g); "
                "rigid velocity error %.2g\n",
                time_step, force_scale, n, m[0], m[1], m[2], F[0] * duration, F[1] * duration, F[2] * duration,
                worst_rigid / size);

    // Drift: no force; momentum stays, elastic energy never grows.
    std::fill_n(in.force, 3, 0.0);
    double previous_energy = HUGE_VAL;
    bool   energy_grew     = false;
    for (std::uint32_t t = 0; t < n; ++t)
      {
        ENSURE(modalrt_kernel_tick_admittance(kernel, &in, 1, &out) == MODALRT_OK);
        std::copy_n(out.position, 3, in.position);
        modalrt_kernel_get_modal_state(kernel, q.data(), v.data(), p.r, nullptr);
        double energy = 0.;
        for (std::uint32_t i = n_rigid; i < p.r; ++i)
          energy += 0.5 * (v[i] * v[i] + p.lambda[i] * q[i] * q[i]);
        energy_grew     = energy_grew || energy > previous_energy * (1 + 1e-12) + 1e-300;
        previous_energy = energy;
        for (double x : out.position)
          finite = finite && std::isfinite(x);
      }
    const auto drift = momentum(p, v);
    for (int k = 0; k < 3; ++k)
      ENSURE_NEAR(drift[k], F[k] * duration, 1e-8 * force_scale * duration);
    ENSURE(!energy_grew);
    ENSURE(finite);
    modalrt_kernel_destroy(kernel);
  }
} // namespace

int main(int argc, char **argv)
{
  if (argc != 2)
    {
      std::fprintf(stderr, "usage: %s BASIS.mrt\n", argv[0]);
      return 2;
    }
  modalrt_basis *basis = nullptr;
  if (modalrt_basis_load(argv[1], &basis) != MODALRT_OK)
    {
      std::fprintf(stderr, "%s\n", modalrt_last_error_message());
      return 1;
    }
  const Part part = read_part(basis, argv[1]);
  check_stored_modes(part);
  check_self_check(part);
  check_push_and_drift(part, 1e-3, 1.0, 1000);
  check_push_and_drift(part, 1e-6, 1.0, 2000);
  check_push_and_drift(part, 0.1, 1.0, 100);
  check_push_and_drift(part, 1e-3, 1e6, 100);
  modalrt_basis_destroy(basis);
  return test::finish("test_free_floating_kernel");
}
