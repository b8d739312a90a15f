#include "allocator.h"

#include "error.h"

#include <atomic>
#include <cstdlib>

namespace modalrt
{
  namespace
  {
    modalrt_allocator hooks{nullptr, nullptr, nullptr};
    std::atomic<long> live_objects{0};
  } // namespace

  void *allocate(std::size_t bytes, std::size_t alignment)
  {
    void *p = hooks.allocate ? hooks.allocate(bytes, alignment, hooks.user)
                             : ::operator new(bytes, std::align_val_t(alignment), std::nothrow);
    if (!p && bytes > 0)
      throw std::bad_alloc();
    return p;
  }

  void deallocate(void *pointer, std::size_t bytes, std::size_t alignment) noexcept
  {
    if (!pointer)
      return;
    if (hooks.deallocate)
      hooks.deallocate(pointer, bytes, alignment, hooks.user);
    else
      ::operator delete(pointer, std::align_val_t(alignment));
  }

  void object_created() noexcept { live_objects.fetch_add(1, std::memory_order_relaxed); }
  void object_destroyed() noexcept { live_objects.fetch_sub(1, std::memory_order_relaxed); }
} // namespace modalrt

extern "C" int modalrt_set_allocator(const modalrt_allocator *allocator)
{
  if (allocator && (!allocator->allocate) != (!allocator->deallocate))
    return modalrt::failed(MODALRT_ERROR_INVALID_ARGUMENT,
                           "modalrt_set_allocator: allocate and deallocate must both be set (or both NULL)");
  if (modalrt::live_objects.load() != 0)
    return modalrt::failed(MODALRT_ERROR_STATE, "modalrt_set_allocator: a basis, kernel or snapshot still exists (set "
                                                "the hooks before loading anything, or after destroying everything)");
  modalrt::hooks = allocator ? *allocator : modalrt_allocator{nullptr, nullptr, nullptr};
  return MODALRT_OK;
}
