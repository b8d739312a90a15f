#include "snapshot.h"

#include <algorithm>

namespace modalrt
{
  void SnapshotState::allocate(std::uint32_t max_modes, std::uint32_t hip_capacity)
  {
    q.assign(max_modes, 0.0);
    contact_vertices.assign(hip_capacity, MODALRT_NONE);
    contact_corrections.assign(3 * std::size_t(hip_capacity), 0.0);
  }

  void SnapshotState::copy_from(const SnapshotState &other)
  {
    tick          = other.tick;
    time          = other.time;
    space         = other.space;
    mode_count    = other.mode_count;
    contact_count = other.contact_count;
    std::copy_n(other.frame_position, 3, frame_position);
    std::copy_n(other.frame_orientation, 4, frame_orientation);
    std::copy_n(other.frame_rotation, 9, frame_rotation);
    std::copy_n(other.q.data(), std::min<std::size_t>(mode_count, q.size()), q.data());
    const std::size_t n = std::min<std::size_t>(contact_count, contact_vertices.size());
    std::copy_n(other.contact_vertices.data(), n, contact_vertices.data());
    std::copy_n(other.contact_corrections.data(), 3 * n, contact_corrections.data());
  }

  void SnapshotExchange::allocate(std::uint32_t max_modes, std::uint32_t hip_capacity)
  {
    for (SnapshotState &s : slots_)
      s.allocate(max_modes, hip_capacity);
  }

  void SnapshotExchange::publish()
  {
    // Release: the display thread that takes this slot sees everything written into it.
    const std::uint32_t previous = middle_.exchange(back_ | fresh_bit, std::memory_order_acq_rel);
    back_                        = previous & 3u;
  }

  const SnapshotState &SnapshotExchange::acquire(bool &fresh)
  {
    fresh = (middle_.load(std::memory_order_relaxed) & fresh_bit) != 0;
    if (fresh)
      {
        const std::uint32_t previous = middle_.exchange(front_, std::memory_order_acq_rel);
        front_                       = previous & 3u;
      }
    return slots_[front_];
  }
} // namespace modalrt
