// The display snapshot: what the display thread needs to redraw the part, published by the tick
// through a triple buffer (wait-free on both sides: the tick never waits for the display, the
// display never sees a half-written state).
#pragma once

#include "allocator.h"

#include <modalrt/modalrt.h>

#include <atomic>
#include <cstdint>
#include <vector>

namespace modalrt
{
  // One published state. Buffers are sized at creation; copying between two states of the same
  // capacities never allocates.
  struct SnapshotState
  {
    std::uint64_t tick          = 0;
    double        time          = 0.0;
    std::uint32_t space         = 0;
    std::uint32_t mode_count    = 0;
    std::uint32_t contact_count = 0;
    double        frame_position[3]    = {0.0, 0.0, 0.0};
    double        frame_orientation[4] = {1.0, 0.0, 0.0, 0.0};
    double        frame_rotation[9]    = {1, 0, 0, 0, 1, 0, 0, 0, 1}; // row-major, body to world
    modalrt::Vector<double>        q;                  // max_modes
    modalrt::Vector<std::uint32_t> contact_vertices;   // hip_capacity, first contact_count used
    modalrt::Vector<double>        contact_corrections; // 3 hip_capacity [m] body frame

    void allocate(std::uint32_t max_modes, std::uint32_t hip_capacity);
    void copy_from(const SnapshotState &other); // no allocation
  };

  // The exchange must not fall back on a hidden mutex.
  static_assert(std::atomic<std::uint32_t>::is_always_lock_free, "the snapshot exchange needs lock-free atomics");

  class SnapshotExchange
  {
  public:
    void allocate(std::uint32_t max_modes, std::uint32_t hip_capacity);

    // Tick side: fill back(), then publish() it.
    SnapshotState &back() { return slots_[back_]; }
    void           publish();

    // Display side (one thread at a time): the newest published state; `fresh` tells whether it
    // is newer than the previous acquire.
    const SnapshotState &acquire(bool &fresh);

  private:
    static constexpr std::uint32_t fresh_bit = 4;
    SnapshotState                  slots_[3];
    std::uint32_t                  back_  = 0; // owned by the tick thread
    std::uint32_t                  front_ = 2; // owned by the display thread
    std::atomic<std::uint32_t>     middle_{1}; // index | fresh_bit
  };
} // namespace modalrt

// The display thread's copy of a published state.
struct modalrt_snapshot : modalrt::HookAllocated
{
  const modalrt_basis   *basis = nullptr;
  const modalrt_kernel  *owner = nullptr; // the kernel it was created for: the only one it reads
  modalrt::SnapshotState state;
  modalrt::Vector<float>     q_f32; // q in float, for the float32 display modes
};
