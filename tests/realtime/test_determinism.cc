// Determinism: a scripted session hashes to the same value every time it runs, with or without a
// display thread reading snapshots alongside; the hash is printed so that runs and builds can be
// compared (set MODALRT_EXPECTED_HASH to check against a recorded value).
#include "scripted_session.h"

#include <atomic>
#include <cstdlib>
#include <thread>

namespace
{
  std::uint64_t session_hash(const modalrt::BasisContent &content, bool with_display)
  {
    test::Session s;
    test::open(s, content);
    std::atomic<bool> done{false};
    std::thread       display;
    modalrt_snapshot *snapshot = nullptr;
    std::vector<float> positions;
    if (with_display)
      {
        modalrt_snapshot_create(s.kernel, &snapshot);
        modalrt_basis_info info;
        modalrt_basis_get_info(s.basis, &info);
        positions.resize(3 * info.display_vertex_count);
        display = std::thread([&, n = info.display_vertex_count] {
          while (!done.load())
            if (modalrt_kernel_snapshot_read(s.kernel, snapshot) == 1)
              modalrt_display_reconstruct(snapshot, 0, n, MODALRT_DISPLAY_POSITIONS, positions.data());
        });
      }
    test::run(s, 0, 20000);
    done = true;
    if (with_display)
      display.join();
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(s.kernel, &stats);
    std::vector<double> q(64);
    std::uint32_t       r;
    modalrt_kernel_get_modal_state(s.kernel, q.data(), nullptr, 64, &r);
    s.fold(q.data(), r * sizeof(double));
    std::printf("  session: %llu switches, %llu clamped forces, hash %016llx\n", (unsigned long long)stats.switch_count,
                (unsigned long long)stats.clamped_forces, (unsigned long long)s.hash);
    ENSURE(stats.switch_count >= 2);
    modalrt_snapshot_destroy(snapshot);
    test::close(s);
    return s.hash;
  }
} // namespace

int main()
{
  const modalrt::BasisContent content = modalrt::make_lattice_cantilever(test::session_lattice());
  const std::uint64_t         first   = session_hash(content, false);
  const std::uint64_t         second  = session_hash(content, false);
  const std::uint64_t         third   = session_hash(content, true);
  ENSURE(first == second);
  ENSURE(first == third);
  if (const char *expected = std::getenv("MODALRT_EXPECTED_HASH"))
    ENSURE(std::strtoull(expected, nullptr, 16) == first);
  return test::finish("test_determinism");
}
