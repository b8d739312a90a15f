// A wait-free triple buffer for one writer thread and one reader thread: the writer never waits for
// the reader (the haptic thread publishes through it), the reader never sees a half-written value.
// T is trivially copyable; nothing allocates after construction.
#pragma once

#include <atomic>
#include <cstdint>
#include <type_traits>

namespace modalrt_view
{
  template <typename T>
  class TripleBuffer
  {
    static_assert(std::is_trivially_copyable<T>::value, "TripleBuffer holds plain values");
    static_assert(std::atomic<std::uint32_t>::is_always_lock_free, "the exchange needs lock-free atomics");

  public:
    // Writer: write the value, then publish it.
    void publish(const T &value)
    {
      slots_[back_] = value;
      back_ = middle_.exchange(back_ | fresh_bit, std::memory_order_acq_rel) & index_mask;
    }

    // Reader: the newest published value; returns true if it is newer than the previous read.
    bool read(T &value)
    {
      bool fresh = false;
      if (middle_.load(std::memory_order_relaxed) & fresh_bit)
        {
          front_ = middle_.exchange(front_, std::memory_order_acq_rel) & index_mask;
          fresh  = true;
        }
      value = slots_[front_];
      return fresh;
    }

  private:
    static constexpr std::uint32_t fresh_bit = 4, index_mask = 3;
    T                              slots_[3] = {};
    std::uint32_t                  back_     = 0; // writer's
    std::uint32_t                  front_    = 2; // reader's
    std::atomic<std::uint32_t>     middle_{1};
  };
} // namespace modalrt_view
