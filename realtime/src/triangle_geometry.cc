// The closest point of a triangle (triangle_geometry.h).
#include "triangle_geometry.h"

#include "vector3.h"

namespace modalrt
{
  void closest_point_weights(const double x[3], const double a[3], const double b[3], const double c[3], double w[3])
  {
    auto set = [w](double wa, double wb, double wc) { w[0] = wa, w[1] = wb, w[2] = wc; };
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    for (int d = 0; d < 3; ++d)
      ab[d] = b[d] - a[d], ac[d] = c[d] - a[d], ap[d] = x[d] - a[d], bp[d] = x[d] - b[d], cp[d] = x[d] - c[d];
    const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0)
      return set(1.0, 0.0, 0.0);
    const double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    if (d3 >= 0.0 && d4 <= d3)
      return set(0.0, 1.0, 0.0);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
      return set(1.0 - d1 / (d1 - d3), d1 / (d1 - d3), 0.0);
    const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0.0 && d5 <= d6)
      return set(0.0, 0.0, 1.0);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
      return set(1.0 - d2 / (d2 - d6), 0.0, d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
      {
        const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return set(0.0, 1.0 - t, t);
      }
    const double denominator = 1.0 / (va + vb + vc), v = vb * denominator, t = vc * denominator;
    set(1.0 - v - t, v, t);
  }
} // namespace modalrt
