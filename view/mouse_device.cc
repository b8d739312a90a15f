#include "mouse_device.h"

#include <cstdlib>
#include <sstream>

namespace modalrt_view
{
  MouseDevice::MouseDevice(const modalrt_basis *basis)
    : vertices_(modalrt_basis_display_vertices(basis)), normals_(modalrt_basis_display_normals(basis)),
      spec_(modalrt_tool::default_device_spec("mouse"))
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    vertex_count_ = info.display_vertex_count;
    modalrt_tool::park_position(info, park_);
    exchange_.publish(requested_);
  }

  std::string MouseDevice::command(const std::string &text)
  {
    std::istringstream in(text);
    std::string        verb;
    unsigned long      hip = 0;
    in >> verb >> hip;
    if (!in || hip >= hips)
      return "error: '" + text + "': expected 'press HIP VERTEX FORCE' or 'release HIP' with HIP < 2";
    if (verb == "press")
      return press(hip, in, text);
    if (verb != "release")
      return "error: '" + text + "': expected 'press HIP VERTEX FORCE' or 'release HIP'";
    requested_.pressed[hip] = 0;
    exchange_.publish(requested_);
    return "ok";
  }

  std::string MouseDevice::press(unsigned long hip, std::istringstream &in, const std::string &text)
  {
    unsigned long vertex = 0;
    std::string   force_text;
    in >> vertex >> force_text;
    if (!in || vertex >= vertex_count_)
      return "error: '" + text + "': expected 'press HIP VERTEX FORCE' with VERTEX < " + std::to_string(vertex_count_);
    // The force magnitude [N] pushes along the inward normal. It is not range-checked here: a
    // non-finite or absurd force reaches the kernel, which rejects it as it would any device's.
    const double magnitude  = std::strtod(force_text.c_str(), nullptr);
    requested_.pressed[hip] = 1;
    requested_.vertex[hip]  = std::uint32_t(vertex);
    for (int d = 0; d < 3; ++d)
      requested_.force[hip][d] = -magnitude * normals_[3 * vertex + d];
    exchange_.publish(requested_);
    return "ok";
  }

  bool MouseDevice::read_state(double, modalrt_hip_input *inputs)
  {
    exchange_.read(mouse_);
    for (std::uint32_t h = 0; h < hips; ++h)
      {
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

  // Contact at the pressed vertex until the kernel holds it there; released when let go.
  modalrt_tool::ContactRequest MouseDevice::contact_request(std::uint32_t hip)
  {
    const modalrt_hip_output &last = last_[hip];
    if (mouse_.pressed[hip] && (!last.in_contact || last.active_vertex != mouse_.vertex[hip]))
      return {modalrt_tool::ContactRequest::press, mouse_.vertex[hip]};
    if (!mouse_.pressed[hip] && last.in_contact)
      return {modalrt_tool::ContactRequest::release, 0};
    return {};
  }
} // namespace modalrt_view
