// No allocation in a tick: global operator new/delete and the C allocator are replaced in this
// program by counting versions. Over 10^4 ticks of a scripted session (contacts, releases,
// switches, frame changes, both steps), with a display thread reading snapshots and reconstructing
// the surface alongside, the count must not move.
#include "scripted_session.h"

#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>

namespace
{
  std::atomic<long> allocations{0};
  std::atomic<bool> counting{false};

  void *counted(std::size_t size)
  {
    if (counting.load(std::memory_order_relaxed))
      allocations.fetch_add(1, std::memory_order_relaxed);
    if (void *p = std::malloc(size ? size : 1))
      return p;
    throw std::bad_alloc();
  }
} // namespace

void *operator new(std::size_t size) { return counted(size); }
void *operator new[](std::size_t size) { return counted(size); }
void *operator new(std::size_t size, const std::nothrow_t &) noexcept
{
  try
    {
      return counted(size);
    }
  catch (...)
    {
      return nullptr;
    }
}
void *operator new[](std::size_t size, const std::nothrow_t &t) noexcept { return operator new(size, t); }
void  operator delete(void *p) noexcept { std::free(p); }
void  operator delete[](void *p) noexcept { std::free(p); }
void  operator delete(void *p, std::size_t) noexcept { std::free(p); }
void  operator delete[](void *p, std::size_t) noexcept { std::free(p); }

#if defined(__GLIBC__)
// The C allocator too (glibc exports its implementation as __libc_*).
extern "C" {
void *__libc_malloc(std::size_t);
void *__libc_calloc(std::size_t, std::size_t);
void *__libc_realloc(void *, std::size_t);
void  __libc_free(void *);

void *malloc(std::size_t size)
{
  if (counting.load(std::memory_order_relaxed))
    allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
void *calloc(std::size_t n, std::size_t size)
{
  if (counting.load(std::memory_order_relaxed))
    allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void *realloc(void *p, std::size_t size)
{
  if (counting.load(std::memory_order_relaxed))
    allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, size);
}
void free(void *p) { __libc_free(p); }
}
#endif

int main()
{
  // Make sure the counter works before trusting a zero.
  counting = true;
  delete new int(7);
  void *block = std::malloc(16);
  std::free(block);
  counting = false;
  ENSURE(allocations.load() >= 2);
  allocations = 0;

  test::Session s;
  test::open(s, modalrt::make_lattice_cantilever(test::session_lattice()));
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
    while (!done.load())
      if (modalrt_kernel_snapshot_read(s.kernel, snapshot) == 1)
        {
          modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count, MODALRT_DISPLAY_POSITIONS, positions.data());
          frames.fetch_add(1, std::memory_order_relaxed);
        }
  });

  test::run(s, 0, 100); // warm-up: first contacts
  counting = true;
  go       = true;
  test::run(s, 100, 10100);
  // Keep ticking until the display thread has drawn a few frames alongside (on a loaded machine
  // 10^4 fast ticks may be over before it is scheduled).
  for (int n = 10100; frames.load() < 50 && n < 1000000; n += 100)
    test::run(s, n, n + 100);
  done = true;
  display.join();
  counting = false;

  modalrt_kernel_stats stats;
  modalrt_kernel_get_stats(s.kernel, &stats);
  std::printf("  %llu ticks, %llu switches, %ld display frames, %ld allocations\n", (unsigned long long)stats.tick_count,
              (unsigned long long)stats.switch_count, frames.load(), allocations.load());
  ENSURE(allocations.load() == 0);
  ENSURE(stats.switch_count >= 2 && frames.load() > 0);
  modalrt_snapshot_destroy(snapshot);
  test::close(s);
  return test::finish("test_no_allocation");
}
