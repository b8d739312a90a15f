// No allocation in a tick: modal-rt's allocation counter (realtime/tools/allocation_counter.cc)
// replaces global operator new/delete and, on glibc, the C allocator with versions that count in
// the threads that switch counting on: here the tick thread and the display thread. Over 10^4
// ticks of a scripted session (contacts, releases, switches, frame changes, both steps), with the
// display thread reading snapshots and reconstructing the surface alongside, the count must not move.
// The basis carries a validity map, and the kernel its 1 % level with validity_clamp on.
#include "allocation_counter.h"
#include "scripted_session.h"

#include <atomic>
#include <cstdlib>
#include <thread>

int main()
{
  // Make sure the counter works before trusting a zero: operator new and malloc both count (direct
  // calls, through a volatile pointer: the compiler may drop an allocation whose result is unused).
  modalrt_tool::count_allocations_in_this_thread(true);
  ::operator delete(::operator new(1));
  void *volatile block = std::malloc(16);
  std::free(block);
  modalrt_tool::count_allocations_in_this_thread(false);
  ENSURE(modalrt_tool::counted_allocations() >= 2);

  test::Session s;
  modalrt::LatticeOptions options = test::session_lattice();
  options.validity_force          = true;
  test::open(s, modalrt::make_lattice_cantilever(options), 1, 1);
  modalrt_snapshot *snapshot = nullptr;
  modalrt_snapshot_create(s.kernel, &snapshot);
  modalrt_basis_info info;
  modalrt_basis_get_info(s.basis, &info);
  std::vector<float>  positions(3 * info.display_vertex_count);
  std::atomic<bool>   go{false}, done{false};
  std::atomic<long>   frames{0};
  std::thread         display([&] {
    while (!go.load())
      std::this_thread::yield();
    modalrt_tool::count_allocations_in_this_thread(true);
    while (!done.load())
      if (modalrt_kernel_snapshot_read(s.kernel, snapshot) == 1)
        {
          modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count, MODALRT_DISPLAY_POSITIONS, positions.data());
          frames.fetch_add(1, std::memory_order_relaxed);
        }
  });

  test::run(s, 0, 100); // warm-up: first contacts
  const std::uint64_t before = modalrt_tool::counted_allocations();
  modalrt_tool::count_allocations_in_this_thread(true);
  go = true;
  test::run(s, 100, 10100);
  // Keep ticking until the display thread has drawn a few frames alongside (on a loaded machine
  // 10^4 fast ticks may be over before it is scheduled).
  for (int n = 10100; frames.load() < 50 && n < 1000000; n += 100)
    test::run(s, n, n + 100);
  done = true;
  display.join();
  modalrt_tool::count_allocations_in_this_thread(false);
  const std::uint64_t allocations = modalrt_tool::counted_allocations() - before;

  modalrt_kernel_stats stats;
  modalrt_kernel_get_stats(s.kernel, &stats);
  std::printf("  %llu ticks, %llu switches, %llu outputs beyond their validity force, %ld display frames, %llu allocations\n",
              (unsigned long long)stats.tick_count, (unsigned long long)stats.switch_count,
              (unsigned long long)s.beyond, frames.load(), (unsigned long long)allocations);
  ENSURE(allocations == 0);
  ENSURE(s.beyond > 0);
  ENSURE(stats.switch_count >= 2 && frames.load() > 0);
  modalrt_snapshot_destroy(snapshot);
  test::close(s);
  return test::finish("test_no_allocation");
}
