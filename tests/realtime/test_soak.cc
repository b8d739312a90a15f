// Soak: a long random session on the two-space lattice. Eight kernels share the basis, with time
// steps from 1e-6 to 0.1 s (log-uniform); bursts of 1 to 2000 admittance ticks run on one of them at
// a time, each burst after a random event (a press on a random vertex, a release, a switch of space,
// or nothing) and with forces on the pressed HIPs of 1e-6 to 1e6 N (log-uniform, random directions)
// or, one burst in three, none. Asserted over every tick:
//   * every output and every modal coordinate and velocity is finite;
//   * the modal energy E = 1/2 sum(v^2 + lambda q^2) stays below a bound set by the largest force:
//     1/2 (hips F_max)^2 g_max / zeta_min^2, g_max the largest contact compliance of the basis (the
//     static energy of the worst contact) and 1/zeta_min^2 a margin above any resonant build-up;
//   * E never grows in a tick without input force (nor space switch: a transfer is a projection);
//   * no input is rejected (the forces are meant to reach the modes) and nothing is allocated after
//     the kernels are created (realtime/tools/allocation_counter.cc counts this thread).
//
//   test_soak [TICKS]     default 1e6 (ctest); docs/reliability.md quotes a run of 1e7
#include "allocation_counter.h"
#include "test_support.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>

namespace
{
  constexpr std::uint32_t hips     = 2;
  constexpr std::uint32_t kernels  = 8;
  constexpr double        max_force = 1e6; // [N]

  struct Figures
  {
    std::uint64_t ticks = 0, zero_force_ticks = 0, presses = 0, releases = 0, switches = 0, non_finite = 0,
                  energy_growths = 0, over_bound = 0;
    double        max_energy = 0.0, max_growth = 0.0;
  };

  // 1/2 sum(v^2 + lambda q^2) of the active space, or NaN if a state component is not finite.
  double modal_energy(const modalrt_kernel *kernel, const modalrt_basis *basis, double *q, double *v,
                      std::uint32_t capacity)
  {
    std::uint32_t r = 0;
    modalrt_kernel_get_modal_state(kernel, q, v, capacity, &r);
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(kernel, &stats);
    const double *lambda = modalrt_basis_eigenvalues(basis, stats.active_space);
    double        energy = 0.0;
    for (std::uint32_t i = 0; i < r; ++i)
      energy += 0.5 * (v[i] * v[i] + lambda[i] * q[i] * q[i]);
    return energy;
  }

  // The largest Frobenius norm (>= the spectral norm) of a contact compliance over every vertex of
  // every space, and the smallest damping ratio: together they bound the energy forces can store.
  void energy_scales(const modalrt_basis *basis, double &g_max, double &zeta_min)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    g_max = 0.0, zeta_min = 1.0;
    for (std::uint32_t s = 0; s < info.space_count; ++s)
      {
        modalrt_space_info space;
        modalrt_basis_get_space_info(basis, s, &space);
        const double *zeta = modalrt_basis_damping_ratios(basis, s);
        zeta_min           = std::min(zeta_min, *std::min_element(zeta, zeta + space.mode_count));
        for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
          {
            double G[9];
            if (modalrt_basis_contact_compliance(basis, s, v, G, nullptr) != MODALRT_OK)
              continue;
            double norm = 0.0;
            for (double g : G)
              norm += g * g;
            g_max = std::max(g_max, std::sqrt(norm));
          }
      }
  }
} // namespace

int main(int argc, char **argv)
{
  const std::uint64_t ticks = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 1000000;
  modalrt::LatticeOptions o;
  o.patch_radius = 0.03;
  modalrt_basis *basis = test::load(modalrt::make_lattice_cantilever(o));
  modalrt_basis_info info;
  modalrt_basis_get_info(basis, &info);
  const double *rest = modalrt_basis_display_vertices(basis);
  double        g_max, zeta_min;
  energy_scales(basis, g_max, zeta_min);
  const double energy_bound = 0.5 * (hips * max_force) * (hips * max_force) * g_max / (zeta_min * zeta_min);

  std::mt19937_64                        random(20261123);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  auto log_uniform = [&](double low, double high) { return low * std::pow(high / low, uniform(random)); };

  modalrt_kernel *kernel[kernels];
  double          time_step[kernels];
  for (std::uint32_t k = 0; k < kernels; ++k)
    {
      modalrt_kernel_def def = modalrt_kernel_default_def();
      // The first and last kernels sit at the ends of the range.
      def.time_step        = k == 0 ? 1e-6 : k == kernels - 1 ? 0.1 : log_uniform(1e-6, 0.1);
      def.hip_capacity     = hips;
      def.auto_release     = 0;   // contacts start and end by the script only
      def.max_input_force  = 1e7; // 1e6 N is a force to apply, not an absurd one
      // Sampled passivity (K T / 2 < b + D) at the longest steps; the coupling is idle in admittance.
      def.coupling_stiffness = std::min(def.coupling_stiffness, def.coupling_damping / def.time_step);
      kernel[k]              = test::create(basis, def);
      time_step[k]           = def.time_step;
    }

  std::vector<double> q(info.max_modes), v(info.max_modes);
  modalrt_hip_input   in[hips]{};
  modalrt_hip_output  out[hips];
  bool                pressed[kernels][hips] = {};
  std::uint32_t       vertex[kernels][hips]  = {};
  Figures             f;

  // The counter counts: one allocation with counting on must show (a direct call: the compiler may
  // drop a new-expression whose result is unused). ENSURE builds a string, so it waits until the end.
  modalrt_tool::count_allocations_in_this_thread(true);
  ::operator delete(::operator new(1));
  const std::uint64_t allocations_before = modalrt_tool::counted_allocations();

  const auto start = std::chrono::steady_clock::now();
  while (f.ticks < ticks)
    {
      const std::uint32_t k = std::uint32_t(uniform(random) * kernels) % kernels;
      const std::uint32_t h = std::uint32_t(uniform(random) * hips) % hips;
      const double        event = uniform(random);
      if (event < 0.3)
        {
          vertex[k][h] = std::uint32_t(uniform(random) * info.display_vertex_count) % info.display_vertex_count;
          pressed[k][h] = modalrt_kernel_contact_begin(kernel[k], h, vertex[k][h]) == MODALRT_OK;
          f.presses += pressed[k][h];
        }
      else if (event < 0.45)
        {
          modalrt_kernel_release_hip(kernel[k], h);
          pressed[k][h] = false;
          ++f.releases;
        }
      else if (event < 0.6)
        f.switches += modalrt_kernel_switch_space(kernel[k], std::uint32_t(uniform(random) * info.space_count) %
                                                               info.space_count) == MODALRT_OK;

      const bool          zero_force = uniform(random) < 1.0 / 3.0;
      const std::uint64_t burst      = std::min<std::uint64_t>(1 + std::uint64_t(uniform(random) * 2000), ticks - f.ticks);
      for (std::uint32_t j = 0; j < hips; ++j)
        {
          // A pressed HIP sits on its vertex; a free one 1 m above the part, where nothing snaps.
          for (int d = 0; d < 3; ++d)
            in[j].position[d] = pressed[k][j] ? rest[3 * vertex[k][j] + d] : (d == 2 ? 1.0 : 0.0);
          const double magnitude = zero_force ? 0.0 : log_uniform(1e-6, max_force);
          double       direction[3], norm = 0.0;
          for (double &x : direction)
            x = uniform(random) - 0.5, norm += x * x;
          for (int d = 0; d < 3; ++d)
            in[j].force[d] = magnitude * direction[d] / std::sqrt(norm);
        }

      double energy = modal_energy(kernel[k], basis, q.data(), v.data(), info.max_modes);
      for (std::uint64_t n = 0; n < burst; ++n, ++f.ticks)
        {
          modalrt_kernel_stats before, after;
          modalrt_kernel_get_stats(kernel[k], &before);
          modalrt_kernel_tick_admittance(kernel[k], in, hips, out);
          modalrt_kernel_get_stats(kernel[k], &after);
          const double next = modal_energy(kernel[k], basis, q.data(), v.data(), info.max_modes);
          if (!std::isfinite(next) || !test::finite(out[0]) || !test::finite(out[1]))
            ++f.non_finite;
          f.max_energy = std::max(f.max_energy, next);
          f.over_bound += next > energy_bound;
          if (zero_force && after.switch_count == before.switch_count)
            {
              ++f.zero_force_ticks;
              // Relative 1e-12: rounding of the state update, far below any real growth.
              if (next > energy * (1.0 + 1e-12) + 1e-300)
                {
                  ++f.energy_growths;
                  f.max_growth = std::max(f.max_growth, next / energy - 1.0);
                }
            }
          energy = next;
        }
    }
  const double        seconds     = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::uint64_t allocations = modalrt_tool::counted_allocations() - allocations_before;
  modalrt_tool::count_allocations_in_this_thread(false);

  std::uint64_t rejected = 0, kernel_switches = 0;
  for (std::uint32_t k = 0; k < kernels; ++k)
    {
      modalrt_kernel_stats stats;
      modalrt_kernel_get_stats(kernel[k], &stats);
      rejected += stats.rejected_ticks;
      kernel_switches += stats.switch_count;
      modalrt_kernel_destroy(kernel[k]);
    }
  std::printf("  %llu ticks in %.2f s (%.3f us/tick) over time steps %.1e..%.1e s: %llu presses, %llu releases, "
              "%llu explicit and %llu total switches\n",
              (unsigned long long)f.ticks, seconds, 1e6 * seconds / double(f.ticks),
              *std::min_element(time_step, time_step + kernels), *std::max_element(time_step, time_step + kernels),
              (unsigned long long)f.presses, (unsigned long long)f.releases, (unsigned long long)f.switches,
              (unsigned long long)kernel_switches);
  std::printf("  max modal energy %.3e J (bound %.3e J), %llu non-finite ticks, %llu zero-force ticks with %llu "
              "energy growths (max %.1e relative), %llu rejected ticks, %llu allocations\n",
              f.max_energy, energy_bound, (unsigned long long)f.non_finite, (unsigned long long)f.zero_force_ticks,
              (unsigned long long)f.energy_growths, f.max_growth, (unsigned long long)rejected,
              (unsigned long long)allocations);

  ENSURE(allocations_before >= 1);
  ENSURE(f.ticks == ticks);
  ENSURE(f.non_finite == 0);
  ENSURE(f.over_bound == 0 && f.max_energy > 0.0);
  ENSURE(f.zero_force_ticks > ticks / 10 && f.energy_growths == 0);
  ENSURE(rejected == 0);
  ENSURE(allocations == 0);
  ENSURE(f.presses > 0 && f.releases > 0 && kernel_switches > f.switches);
  modalrt_basis_destroy(basis);
  return test::finish("test_soak");
}
