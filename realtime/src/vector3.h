// Small 3-vector and rotation helpers of the kernel (body <-> world frames).
#pragma once

#include <algorithm>
#include <cmath>

namespace modalrt
{
  inline double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  inline double norm3(const double a[3]) { return std::sqrt(dot3(a, a)); }
  inline bool   finite3(const double a[3]) { return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]); }

  inline void cross3(const double a[3], const double b[3], double out[3])
  {
    const double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    std::copy_n(c, 3, out);
  }

  // out = R x, R row-major.
  inline void rotate(const double R[9], const double x[3], double out[3])
  {
    const double y[3] = {R[0] * x[0] + R[1] * x[1] + R[2] * x[2], R[3] * x[0] + R[4] * x[1] + R[5] * x[2],
                         R[6] * x[0] + R[7] * x[1] + R[8] * x[2]};
    std::copy_n(y, 3, out);
  }

  // out = R^T x.
  inline void rotate_back(const double R[9], const double x[3], double out[3])
  {
    const double y[3] = {R[0] * x[0] + R[3] * x[1] + R[6] * x[2], R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
                         R[2] * x[0] + R[5] * x[1] + R[8] * x[2]};
    std::copy_n(y, 3, out);
  }

  // Rotation matrix (row-major) of a unit quaternion w, x, y, z.
  inline void rotation_from_quaternion(const double q[4], double R[9])
  {
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
  }
} // namespace modalrt
