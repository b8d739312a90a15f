// Counts heap allocations made by one thread (the haptic thread, between the first and the last
// tick). The kernel has no allocation counter of its own, so modal-rt replaces the global
// operator new family and, on glibc, malloc/calloc/realloc/aligned allocators with versions that
// count when the calling thread has switched counting on. Other threads (display, file writing)
// are not counted and pay one thread-local read per allocation.
#pragma once

#include <cstdint>

namespace modalrt_tool
{
  // Starts or stops counting the allocations of the calling thread.
  void count_allocations_in_this_thread(bool on);
  // Allocations counted so far, over every thread that switched counting on.
  std::uint64_t counted_allocations();
  // What is replaced, for stats.json ("operator new and malloc family" on glibc).
  const char *allocation_counting_method();
} // namespace modalrt_tool
