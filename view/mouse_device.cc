#include "mouse_device.h"

#include "page_command.h"

#include <algorithm>
#include <cmath>

namespace modalrt_view
{
  namespace
  {
    constexpr double follow_time = 0.03; // [s] the lag with which a sliding HIP follows the pointer
    constexpr double max_depth   = 0.02; // [m] the servo's deepest push below the surface point
    // [s] the servo's time constant: slower than a compliant part's ringing (the lattice's first mode,
    // lightly damped, made a 5 ms servo oscillate and lose the contact).
    constexpr double servo_time = 0.1;
  } // namespace

  MouseDevice::MouseDevice(const modalrt_basis *basis, bool slide)
    : vertices_(modalrt_basis_display_vertices(basis)), normals_(modalrt_basis_display_normals(basis)),
      spec_(modalrt_tool::default_device_spec("mouse")), slide_(slide),
      stiffness_(modalrt_kernel_default_def().coupling_stiffness)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    vertex_count_ = info.display_vertex_count;
    modalrt_tool::park_position(info, park_);
    exchange_.publish(requested_);
  }

  std::string MouseDevice::command(const std::string &text)
  {
    PageCommand       c;
    const std::string error = parse_page_command(text.data(), text.size(), hips, vertex_count_, slide_, c);
    if (!error.empty())
      return error;
    requested_.pressed[c.hip] = c.verb == PageCommand::release ? 0 : 1;
    if (c.verb != PageCommand::release)
      {
        const double *point = c.verb == PageCommand::slide ? c.point : vertices_ + 3 * std::size_t(c.vertex);
        requested_.vertex[c.hip] = c.vertex;
        for (int d = 0; d < 3; ++d)
          {
            requested_.force[c.hip][d] = -c.force * normals_[3 * std::size_t(c.vertex) + d];
            requested_.point[c.hip][d] = point[d];
          }
      }
    exchange_.publish(requested_);
    return "ok";
  }

  void MouseDevice::slide_state(std::uint32_t h, double dt, modalrt_hip_input &input)
  {
    const double *n      = normals_ + 3 * std::size_t(mouse_.vertex[h]);
    const double  wanted = -(mouse_.force[h][0] * n[0] + mouse_.force[h][1] * n[1] + mouse_.force[h][2] * n[2]);
    if (!was_pressed_[h]) // a new press starts at the point, as deep as the coupling alone needs
      {
        std::copy_n(mouse_.point[h], 3, point_[h]);
        depth_[h] = std::clamp(wanted / stiffness_, 0.0, max_depth);
      }
    const double follow = dt > 0.0 ? std::min(1.0, dt / follow_time) : 1.0;
    for (int d = 0; d < 3; ++d)
      point_[h][d] += follow * (mouse_.point[h][d] - point_[h][d]);
    if (last_[h].in_contact)
      {
        const double felt = last_[h].force[0] * n[0] + last_[h].force[1] * n[1] + last_[h].force[2] * n[2];
        depth_[h] = std::clamp(depth_[h] + std::min(1.0, dt / servo_time) * (wanted - felt) / stiffness_, 0.0, max_depth);
      }
    for (int d = 0; d < 3; ++d)
      {
        const double x    = point_[h][d] - depth_[h] * n[d];
        input.position[d] = x;
        input.velocity[d] = was_pressed_[h] && dt > 0.0 ? (x - position_[h][d]) / dt : 0.0;
        input.force[d]    = 0.0;
        position_[h][d]   = x;
      }
  }

  bool MouseDevice::read_state(double t, modalrt_hip_input *inputs)
  {
    exchange_.read(mouse_);
    const double dt = last_time_ >= 0.0 ? t - last_time_ : 0.0;
    last_time_      = t;
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        if (slide_ && mouse_.pressed[h])
          {
            slide_state(h, dt, inputs[h]);
            was_pressed_[h] = 1;
            continue;
          }
        was_pressed_[h] = 0;
        const double *at = mouse_.pressed[h] ? vertices_ + 3 * std::size_t(mouse_.vertex[h]) : park_;
        for (int d = 0; d < 3; ++d)
          {
            inputs[h].position[d] = at[d];
            inputs[h].velocity[d] = 0.0;
            inputs[h].force[d]    = mouse_.pressed[h] ? mouse_.force[h][d] : 0.0;
          }
      }
    return true;
  }

  // Contact at the pressed vertex until the kernel holds it there (sliding: until the kernel holds a
  // contact, which then slides on its own); released when let go.
  modalrt_tool::ContactRequest MouseDevice::contact_request(std::uint32_t hip)
  {
    const modalrt_hip_output &last = last_[hip];
    if (mouse_.pressed[hip] && (!last.in_contact || (!slide_ && last.active_vertex != mouse_.vertex[hip])))
      return {modalrt_tool::ContactRequest::press, mouse_.vertex[hip]};
    if (!mouse_.pressed[hip] && last.in_contact)
      return {modalrt_tool::ContactRequest::release, 0};
    return {};
  }
} // namespace modalrt_view
