// The six rigid-body motions of a part: what the supports may leave free (free_motions.cc), the
// exact 0 Hz modes of a free-floating space, and the AMG preconditioner's near null space.
#pragma once

#include <deal.II/base/tensor.h>

namespace modal_haptics
{
  // Rigid-body motion k at offset x from the centre: translations along x, y, z (k = 0, 1, 2),
  // then rotations about the axes (k = 3, 4, 5).
  inline dealii::Tensor<1, 3> rigid_body_motion(const unsigned int k, const dealii::Tensor<1, 3> &x)
  {
    dealii::Tensor<1, 3> u;
    if (k < 3)
      u[k] = 1.;
    else
      {
        dealii::Tensor<1, 3> axis;
        axis[k - 3] = 1.;
        u           = dealii::cross_product_3d(axis, x);
      }
    return u;
  }
} // namespace modal_haptics
