// The point of a tet of linear geometry (a degree-1 MappingFE) at a point of the reference tet:
// for the supports' FE nodes and the VTU patches' points, without asking the mapping point by point.
#pragma once

#include <deal.II/base/point.h>

namespace modal_haptics
{
  // v_0 N_0 + ... + v_3 N_3 with the linear shape functions N = (1 - x - y - z, x, y, z), summed in
  // the order MappingFE sums them (at the support points of FE_SimplexP of degree 1 or 2, where
  // each N is 0, 1/2 or 1, the same bits as the mapping's point).
  template <typename CellIterator>
  dealii::Point<3> point_in_linear_tet(const CellIterator &cell, const dealii::Point<3> &unit)
  {
    const double     N[4] = {1. - unit[0] - unit[1] - unit[2], unit[0], unit[1], unit[2]};
    dealii::Point<3> x;
    for (unsigned int v = 0; v < 4; ++v)
      x += N[v] * cell->vertex(v);
    return x;
  }
} // namespace modal_haptics
