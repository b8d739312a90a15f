// The moving frame (moving_frame.h).
#include "moving_frame.h"

#include "vector3.h"

#include <algorithm>
#include <cmath>

using namespace modalrt;

void modalrt::to_body(const Frame &fr, const modalrt_hip_input *inputs, std::uint32_t count, BodyInput *body) noexcept
{
  for (std::uint32_t h = 0; h < count; ++h)
    {
      BodyInput &b = body[h];
      double     r[3], w_cross_r[3], relative_velocity[3];
      for (int d = 0; d < 3; ++d)
        r[d] = inputs[h].position[d] - fr.position[d];
      rotate_back(fr.rotation, r, b.x);
      // Velocity seen in the body frame: minus the frame's own motion at that point.
      cross3(fr.angular_velocity, r, w_cross_r);
      for (int d = 0; d < 3; ++d)
        relative_velocity[d] = inputs[h].velocity[d] - fr.linear_velocity[d] - w_cross_r[d];
      rotate_back(fr.rotation, relative_velocity, b.v);
      rotate_back(fr.rotation, inputs[h].force, b.force);
    }
}

// The d'Alembert load M R a projected on the modes.
void modalrt::frame_modal_force(const Frame &frame, const ModalSpace &space, double *f) noexcept
{
  const std::uint32_t r = space.mode_count;
  if (space.participation.empty() || !frame.moving)
    {
      std::fill_n(f, r, 0.0);
      return;
    }
  const double *a = frame.body_acceleration, *G = space.participation.data();
  for (std::uint32_t i = 0; i < r; ++i)
    f[i] = -(G[6 * i] * a[0] + G[6 * i + 1] * a[1] + G[6 * i + 2] * a[2] + G[6 * i + 3] * a[3] +
             G[6 * i + 4] * a[4] + G[6 * i + 5] * a[5]);
}

bool modalrt::set_frame_state(Frame &fr, const modalrt_frame_state &s, const modalrt_kernel_def &def,
                              const double centre_of_mass[3]) noexcept
{
  const double qn = std::sqrt(s.orientation[0] * s.orientation[0] + s.orientation[1] * s.orientation[1] +
                              s.orientation[2] * s.orientation[2] + s.orientation[3] * s.orientation[3]);
  const bool finite = finite3(s.position) && finite3(s.linear_velocity) && finite3(s.angular_velocity) &&
                      finite3(s.linear_acceleration) && finite3(s.angular_acceleration) && std::isfinite(qn);
  if (!finite || qn < 0.5 || qn > 2.0 || norm3(s.position) > def.workspace_radius ||
      norm3(s.linear_velocity) > def.max_input_velocity || norm3(s.linear_acceleration) > def.max_frame_acceleration ||
      norm3(s.angular_acceleration) > def.max_frame_acceleration)
    return false;
  for (int k = 0; k < 4; ++k)
    fr.orientation[k] = s.orientation[k] / qn;
  rotation_from_quaternion(fr.orientation, fr.rotation);
  std::copy_n(s.position, 3, fr.position);
  std::copy_n(s.linear_velocity, 3, fr.linear_velocity);
  std::copy_n(s.angular_velocity, 3, fr.angular_velocity);

  // Acceleration of the centre of mass: a + alpha x c + omega x (omega x c), c = R c_body.
  double c[3], alpha_c[3], omega_c[3], centripetal[3], a_com[3];
  rotate(fr.rotation, centre_of_mass, c);
  cross3(s.angular_acceleration, c, alpha_c);
  cross3(s.angular_velocity, c, omega_c);
  cross3(s.angular_velocity, omega_c, centripetal);
  for (int d = 0; d < 3; ++d)
    a_com[d] = s.linear_acceleration[d] + alpha_c[d] + centripetal[d];
  rotate_back(fr.rotation, a_com, fr.body_acceleration);
  rotate_back(fr.rotation, s.angular_acceleration, fr.body_acceleration + 3);
  fr.moving = false;
  for (double x : fr.body_acceleration)
    fr.moving = fr.moving || x != 0.0;
  return true;
}
