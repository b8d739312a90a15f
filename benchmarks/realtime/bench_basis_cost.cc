// bench-basis-cost: what the real-time kernel costs on one basis file, for modal-study (which may
// not include the kernel: docs/architecture.md) and for anyone with a .mrt at hand.
//
// One HIP in contact at display vertex V, pushing with 1 N along the direction D: the p50 and p99 of
// N admittance ticks after N/10 warm-up ticks, without and with the static correction; then the
// median of 15 reconstructions of the whole display surface of the pressed part.
//
// Usage: bench-basis-cost --basis FILE --vertex V --direction DX,DY,DZ [--ticks N]   (N: 20000)
// Prints one JSON line on stdout:
//   {"tick_p50_ns": .., "tick_p99_ns": .., "corrected_tick_p50_ns": .., "corrected_tick_p99_ns": ..,
//    "display_ms": .., "display_vertices": ..}
// An error: a message on stderr and exit status 1 (2 for a wrong command line).
#include <modalrt/modalrt.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
  struct Options
  {
    std::string           basis_file;
    unsigned int          vertex = 0;
    std::array<double, 3> direction{};
    unsigned int          ticks = 20000;
  };

  struct Cost
  {
    double       tick_p50_ns = 0., tick_p99_ns = 0., corrected_tick_p50_ns = 0., corrected_tick_p99_ns = 0.;
    double       display_ms       = 0.;
    unsigned int display_vertices = 0;
  };

  void check_kernel(const int status, const std::string &what)
  {
    if (status < 0)
      throw std::runtime_error("modalrt: " + what + " failed: " + modalrt_last_error_message());
  }

  template <typename Work>
  double median_seconds(const unsigned int repetitions, const Work &work)
  {
    std::vector<double> seconds;
    for (unsigned int k = 0; k < repetitions; ++k)
      {
        const auto start = std::chrono::steady_clock::now();
        work();
        seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      }
    std::sort(seconds.begin(), seconds.end());
    return seconds[seconds.size() / 2];
  }

  // A kernel on `basis` with one HIP in contact at `vertex`, pushing with 1 N along `direction`.
  struct PressingKernel
  {
    modalrt_kernel   *kernel = nullptr;
    modalrt_hip_input input{};

    PressingKernel(const modalrt_basis *basis, const unsigned int vertex, const std::array<double, 3> &direction,
                   const bool corrected)
    {
      modalrt_kernel_def def    = modalrt_kernel_default_def();
      def.time_step             = 1e-3;
      def.hip_capacity          = 1;
      def.auto_release          = 0;
      def.use_static_correction = corrected ? 1 : 0;
      check_kernel(modalrt_kernel_create(basis, &def, &kernel), "kernel_create");
      check_kernel(modalrt_kernel_contact_begin(kernel, 0, vertex), "kernel_contact_begin");
      const double *rest = modalrt_basis_display_vertices(basis) + 3 * std::size_t(vertex);
      for (unsigned int c = 0; c < 3; ++c)
        input.position[c] = rest[c], input.force[c] = -direction[c];
    }
    ~PressingKernel() { modalrt_kernel_destroy(kernel); }
    PressingKernel(const PressingKernel &) = delete;
    PressingKernel &operator=(const PressingKernel &) = delete;

    int tick()
    {
      modalrt_hip_output output{};
      return modalrt_kernel_tick_admittance(kernel, &input, 1, &output);
    }

    // p50 and p99 [ns] of `ticks` ticks after a warm-up (caches, branch predictors, clock).
    std::array<double, 2> time_ticks(const unsigned int ticks)
    {
      for (unsigned int k = 0; k < ticks / 10; ++k)
        check_kernel(tick(), "kernel_tick_admittance");
      std::vector<double> nanoseconds(ticks);
      for (auto &ns : nanoseconds)
        {
          const auto start  = std::chrono::steady_clock::now();
          const int  status = tick();
          ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
          check_kernel(status, "kernel_tick_admittance");
        }
      std::sort(nanoseconds.begin(), nanoseconds.end());
      return {nanoseconds[ticks / 2], nanoseconds[std::size_t(ticks) * 99 / 100]};
    }
  };

  // The display of the pressed part: every vertex, static correction near the contact included.
  void time_display(const modalrt_basis *basis, modalrt_kernel *kernel, Cost &cost)
  {
    modalrt_basis_info info{};
    check_kernel(modalrt_basis_get_info(basis, &info), "basis_get_info");
    cost.display_vertices      = info.display_vertex_count;
    modalrt_snapshot *snapshot = nullptr;
    check_kernel(modalrt_snapshot_create(kernel, &snapshot), "snapshot_create");
    check_kernel(modalrt_kernel_snapshot_read(kernel, snapshot), "kernel_snapshot_read");
    std::vector<float> displacements(3 * std::size_t(info.display_vertex_count));
    cost.display_ms = 1e3 * median_seconds(15, [&] {
                        check_kernel(modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count, 0,
                                                                 displacements.data()),
                                     "display_reconstruct");
                      });
    modalrt_snapshot_destroy(snapshot);
  }

  Cost measure(const modalrt_basis *basis, const Options &o)
  {
    Cost cost;
    {
      PressingKernel plain(basis, o.vertex, o.direction, false);
      const auto     p = plain.time_ticks(o.ticks);
      cost.tick_p50_ns = p[0], cost.tick_p99_ns = p[1];
    }
    PressingKernel corrected(basis, o.vertex, o.direction, true);
    const auto     p = corrected.time_ticks(o.ticks);
    cost.corrected_tick_p50_ns = p[0], cost.corrected_tick_p99_ns = p[1];
    time_display(basis, corrected.kernel, cost);
    return cost;
  }

  [[noreturn]] void usage()
  {
    std::fprintf(stderr, "usage: bench-basis-cost --basis FILE --vertex V --direction DX,DY,DZ [--ticks N]\n");
    std::exit(2);
  }

  Options parse(const int argc, char **argv)
  {
    Options o;
    bool    has_vertex = false, has_direction = false;
    for (int k = 1; k + 1 < argc; k += 2)
      {
        const std::string arg = argv[k], value = argv[k + 1];
        char             *end = nullptr;
        if (arg == "--basis")
          o.basis_file = value;
        else if (arg == "--vertex")
          o.vertex = unsigned(std::strtoul(value.c_str(), &end, 10)), has_vertex = *end == '\0';
        else if (arg == "--ticks")
          o.ticks = unsigned(std::strtoul(value.c_str(), &end, 10));
        else if (arg == "--direction")
          has_direction = std::sscanf(value.c_str(), "%lf,%lf,%lf", &o.direction[0], &o.direction[1],
                                      &o.direction[2]) == 3;
        else
          usage();
      }
    if (argc % 2 == 0 || o.basis_file.empty() || !has_vertex || !has_direction || o.ticks < 100)
      usage();
    return o;
  }
} // namespace

int main(int argc, char **argv)
{
  const Options o = parse(argc, argv);
  modalrt_thread_enable_flush_to_zero();
  modalrt_basis *basis = nullptr;
  try
    {
      check_kernel(modalrt_basis_load(o.basis_file.c_str(), &basis), "basis_load(" + o.basis_file + ")");
      const Cost c = measure(basis, o);
      std::printf("{\"tick_p50_ns\": %.17g, \"tick_p99_ns\": %.17g, \"corrected_tick_p50_ns\": %.17g, "
                  "\"corrected_tick_p99_ns\": %.17g, \"display_ms\": %.17g, \"display_vertices\": %u}\n",
                  c.tick_p50_ns, c.tick_p99_ns, c.corrected_tick_p50_ns, c.corrected_tick_p99_ns, c.display_ms,
                  c.display_vertices);
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "bench-basis-cost: %s\n", e.what());
      modalrt_basis_destroy(basis);
      return 1;
    }
  modalrt_basis_destroy(basis);
  return 0;
}
