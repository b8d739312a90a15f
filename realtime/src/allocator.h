// The library's memory: every array of a basis, a kernel and a snapshot, and the three objects
// themselves, come from the allocator hooks of modalrt_set_allocator (default: operator new and
// delete). Hooks may change only while no basis, kernel or snapshot exists, so a block is always
// returned to the hooks that gave it. Small strings (file names, messages) use the standard
// allocator.
#pragma once

#include <modalrt/modalrt.h>

#include <cstddef>
#include <new>
#include <vector>

namespace modalrt
{
  void *allocate(std::size_t bytes, std::size_t alignment);            // throws std::bad_alloc
  void  deallocate(void *pointer, std::size_t bytes, std::size_t alignment) noexcept;

  // Objects of the C API alive now (bases, kernels, snapshots): the hooks are fixed while > 0.
  void object_created() noexcept;
  void object_destroyed() noexcept;

  template <typename T>
  struct HookAllocator
  {
    using value_type = T;
    HookAllocator() noexcept = default;
    template <typename U>
    HookAllocator(const HookAllocator<U> &) noexcept
    {}
    T *allocate(std::size_t n)
    {
      if (n > std::size_t(-1) / sizeof(T))
        throw std::bad_alloc();
      return static_cast<T *>(modalrt::allocate(n * sizeof(T), alignof(T)));
    }
    void deallocate(T *p, std::size_t n) noexcept { modalrt::deallocate(p, n * sizeof(T), alignof(T)); }
    template <typename U>
    bool operator==(const HookAllocator<U> &) const noexcept
    {
      return true;
    }
    template <typename U>
    bool operator!=(const HookAllocator<U> &) const noexcept
    {
      return false;
    }
  };

  // The arrays of the library.
  template <typename T>
  using Vector = std::vector<T, HookAllocator<T>>;

  // Base of the C API's objects: allocated through the hooks and counted.
  struct HookAllocated
  {
    HookAllocated() noexcept { object_created(); }
    HookAllocated(const HookAllocated &) noexcept { object_created(); }
    ~HookAllocated() { object_destroyed(); }
    static void *operator new(std::size_t bytes) { return modalrt::allocate(bytes, alignof(std::max_align_t)); }
    static void  operator delete(void *p, std::size_t bytes) noexcept
    {
      modalrt::deallocate(p, bytes, alignof(std::max_align_t));
    }
  };
} // namespace modalrt
