#include "allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

// The sanitizer runtimes must own malloc: they call it while they initialize, before a replacement
// could run, and the program dies with SIGSEGV before main. Under a sanitizer (scripts/test-kernel-checks)
// only operator new is replaced and counted; elsewhere on glibc malloc/calloc/realloc are too.
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define MODALRT_UNDER_SANITIZER 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define MODALRT_UNDER_SANITIZER 1
#endif
#if defined(__GLIBC__) && !defined(MODALRT_UNDER_SANITIZER)
#define MODALRT_REPLACE_MALLOC 1
#else
#define MODALRT_REPLACE_MALLOC 0
#endif

namespace
{
  // Constant-initialized and trivial: reading it never allocates (no TLS constructor to run).
  thread_local bool         counting = false;
  std::atomic<std::uint64_t> allocations{0};

  inline void note_allocation()
  {
    if (counting)
      allocations.fetch_add(1, std::memory_order_relaxed);
  }

  constexpr bool malloc_counts = MODALRT_REPLACE_MALLOC; // then the replaced malloc below counts

  void *allocate(std::size_t size)
  {
    if (!malloc_counts)
      note_allocation();
    if (void *p = std::malloc(size ? size : 1))
      return p;
    throw std::bad_alloc();
  }
} // namespace

namespace modalrt_tool
{
  void          count_allocations_in_this_thread(bool on) { counting = on; }
  std::uint64_t counted_allocations() { return allocations.load(); }
  const char   *allocation_counting_method()
  {
#if MODALRT_REPLACE_MALLOC
    return "global operator new and malloc/calloc/realloc replaced in modal-rt, counted in the haptic thread "
           "from the first tick to the last";
#else
    return "global operator new replaced in modal-rt (malloc not covered on this C library or under a "
           "sanitizer), counted in the haptic thread from the first tick to the last";
#endif
  }
} // namespace modalrt_tool

// The operator new family (over malloc, which counts by itself on glibc).
void *operator new(std::size_t size) { return allocate(size); }
void *operator new[](std::size_t size) { return allocate(size); }
void *operator new(std::size_t size, const std::nothrow_t &) noexcept
{
  if (!malloc_counts)
    note_allocation();
  return std::malloc(size ? size : 1);
}
void *operator new[](std::size_t size, const std::nothrow_t &t) noexcept { return operator new(size, t); }
void  operator delete(void *p) noexcept { std::free(p); }
void  operator delete[](void *p) noexcept { std::free(p); }
void  operator delete(void *p, std::size_t) noexcept { std::free(p); }
void  operator delete[](void *p, std::size_t) noexcept { std::free(p); }
void  operator delete(void *p, const std::nothrow_t &) noexcept { std::free(p); }
void  operator delete[](void *p, const std::nothrow_t &) noexcept { std::free(p); }

#if MODALRT_REPLACE_MALLOC
// glibc exports its allocator as __libc_*: the C allocator is wrapped the same way.
extern "C" {
void *__libc_malloc(std::size_t);
void *__libc_calloc(std::size_t, std::size_t);
void *__libc_realloc(void *, std::size_t);
void  __libc_free(void *);

void *malloc(std::size_t size)
{
  note_allocation();
  return __libc_malloc(size);
}
void *calloc(std::size_t n, std::size_t size)
{
  note_allocation();
  return __libc_calloc(n, size);
}
void *realloc(void *p, std::size_t size)
{
  note_allocation();
  return __libc_realloc(p, size);
}
void free(void *p) { __libc_free(p); }
}
#endif
