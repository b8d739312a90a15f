// The snap contact's search: the closest vertex of the deformed display surface to a HIP, with a
// bounded amount of work per tick (modalrt_kernel_def.snap_candidate_budget vertices evaluated
// deformed).
#pragma once

#include "allocator.h"
#include "basis.h"

#include <cstdint>

namespace modalrt
{
  struct SnapCandidate
  {
    std::uint32_t vertex;
    double        rest_distance_squared;
  };

  class SnapSearch
  {
  public:
    // Allocates room for `budget` candidates; never called in a tick.
    void setup(std::uint32_t budget);

    // The closest vertex to x (body frame) of the surface deformed by q in space `space`, within
    // `snap_distance`: its index, the gap x - its deformed position, and the gap along its normal.
    // False if there is none.
    bool find(const modalrt_basis &basis, std::uint32_t space, const double *q, double snap_distance, const double x[3],
              std::uint32_t &vertex, double gap[3], double &signed_distance) noexcept;

  private:
    modalrt::Vector<SnapCandidate> candidates_; // the nearest at rest, at most the budget
  };

  // u = Phi_v q: display vertex v's displacement in `space`.
  void vertex_displacement(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, const double *q,
                           double u[3]) noexcept;
} // namespace modalrt
