// The geometry of a display triangle that a sliding contact's proxy walks on: the closest point of
// a triangle, its edges' normal equations, a barycentric step along the plane and its advance to the
// first edge reached. Plain functions of positions: no basis, no modal state.
#pragma once

#include "vector3.h"

#include <algorithm>

namespace modalrt
{
  // A triangle's edges e1 = Y1 - Y0, e2 = Y2 - Y0 and their normal equations (the proxy's walk).
  struct TriangleSystem
  {
    double e1[3], e2[3], a11, a12, a22, det, inverse_det;
  };

  // Barycentric weights of the point of triangle (a, b, c) closest to x (Ericson, Real-Time
  // Collision Detection, 5.1.5): >= 0, sum 1; exactly a corner's when x is at that corner.
  void closest_point_weights(const double x[3], const double a[3], const double b[3], const double c[3], double w[3]);

  // The edges of a triangle Y and their normal equations, for barycentric_step.
  inline TriangleSystem triangle_system(const double Y[3][3])
  {
    TriangleSystem t;
    for (int d = 0; d < 3; ++d)
      t.e1[d] = Y[1][d] - Y[0][d], t.e2[d] = Y[2][d] - Y[0][d];
    t.a11 = dot3(t.e1, t.e1), t.a12 = dot3(t.e1, t.e2), t.a22 = dot3(t.e2, t.e2), t.det = t.a11 * t.a22 - t.a12 * t.a12;
    t.inverse_det = 1.0 / t.det;
    return t;
  }

  // Barycentric change dw (sum 0) whose displacement over the triangle is the projection of `step`
  // on its plane (least squares over the two edges). False for a degenerate triangle.
  inline bool barycentric_step(const TriangleSystem &t, const double step[3], double dw[3])
  {
    if (!(t.det > 1e-12 * t.a11 * t.a22))
      return false;
    const double b1 = dot3(step, t.e1), b2 = dot3(step, t.e2);
    const double s1 = (t.a22 * b1 - t.a12 * b2) * t.inverse_det, s2 = (t.a11 * b2 - t.a12 * b1) * t.inverse_det;
    dw[0] = -s1 - s2, dw[1] = s1, dw[2] = s2;
    return true;
  }

  // Moves weights w by s dw, s <= 1 the largest that keeps them >= 0; `exit` is the corner that
  // reached 0 first (-1 if the whole step fits). Returns s.
  inline double advance(double w[3], const double dw[3], int &exit)
  {
    double s = 1.0;
    exit     = -1;
    for (int k = 0; k < 3; ++k)
      if (dw[k] < 0.0 && w[k] + s * dw[k] < 0.0)
        s = w[k] / -dw[k], exit = k;
    double sum = 0.0;
    for (int k = 0; k < 3; ++k)
      sum += (w[k] = k == exit ? 0.0 : std::max(0.0, w[k] + s * dw[k]));
    const double scale = 1.0 / sum;
    for (int k = 0; k < 3; ++k)
      w[k] *= scale;
    return s;
  }
} // namespace modalrt
