// Moving frame: the frame's acceleration drives the modes through the participation factors, and
// inputs and outputs are in world coordinates.
#include "test_support.h"

namespace
{
  void acceleration_drives_modes()
  {
    const modalrt::BasisContent c = modalrt::make_lattice_cantilever();
    modalrt_basis              *b = test::load(c);
    modalrt_kernel             *k = test::create(b, modalrt_kernel_default_def());
    modalrt_frame_state         f = modalrt_frame_state_identity();
    const double                a[6] = {0.5, -1.0, 9.81, 0.0, 0.0, 0.0};
    f.linear_acceleration[0] = a[0];
    f.linear_acceleration[1] = a[1];
    f.linear_acceleration[2] = a[2];
    ENSURE(modalrt_kernel_set_frame(k, &f) == MODALRT_OK);
    modalrt_hip_output out;
    for (int n = 0; n < 30000; ++n)
      modalrt_kernel_tick_admittance(k, nullptr, 0, &out);
    std::vector<double> q(64);
    std::uint32_t       r;
    modalrt_kernel_get_modal_state(k, q.data(), nullptr, 64, &r);
    const auto &space = c.spaces[0];
    for (std::uint32_t i = 0; i < r; ++i)
      {
        double g = 0.0;
        for (int j = 0; j < 6; ++j)
          g += space.participation[6 * i + j] * a[j];
        ENSURE_NEAR(q[i], -g / space.eigenvalues[i], 1e-9 * std::fabs(q[0]));
      }
    // Accelerating upward sags the free end (d'Alembert load downward).
    modalrt_snapshot *s = nullptr;
    modalrt_snapshot_create(k, &s);
    modalrt_kernel_snapshot_read(k, s);
    double u[3];
    modalrt_display_reconstruct_f64(s, 8, 9, 0, u);
    ENSURE(u[2] < 0.0);
    modalrt_snapshot_destroy(s);

    // The same load through settle (exact static equilibrium).
    modalrt_kernel_reset(k);
    modalrt_kernel_settle(k, nullptr, 0);
    std::vector<double> q2(64);
    modalrt_kernel_get_modal_state(k, q2.data(), nullptr, 64, &r);
    for (std::uint32_t i = 0; i < r; ++i)
      ENSURE_NEAR(q2[i], q[i], 1e-9 * std::fabs(q[0]));
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  void world_coordinates()
  {
    modalrt_basis      *b = test::load(modalrt::make_lattice_cantilever());
    modalrt_kernel     *k = test::create(b, modalrt_kernel_default_def());
    modalrt_frame_state f = modalrt_frame_state_identity();
    const double        p[3] = {0.3, -0.2, 1.0};
    // 90 degrees about x: body +z (the top face's normal) points along world -y.
    f.orientation[0] = std::sqrt(0.5);
    f.orientation[1] = std::sqrt(0.5);
    for (int d = 0; d < 3; ++d)
      f.position[d] = p[d];
    ENSURE(modalrt_kernel_set_frame(k, &f) == MODALRT_OK);
    const std::uint32_t v = 16;
    const double       *x = modalrt_basis_display_vertices(b) + 3 * v;
    // World position of the vertex, pushed 1 mm into the part (along world +y).
    const double       world[3] = {p[0] + x[0], p[1] - x[2] + 0.001, p[2] + x[1]};
    modalrt_hip_input  in = test::hip_at(world, 0.0, 1.0, 0.0); // pushing along world +y = body -z
    modalrt_hip_output out;
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE(out.in_contact == 1 && out.active_vertex == v);
    for (int n = 0; n < 100; ++n)
      modalrt_kernel_tick_admittance(k, &in, 1, &out);
    ENSURE_NEAR(out.position[0], p[0] + x[0], 1e-3);
    ENSURE(out.position[1] > p[1] - x[2]); // the surface moved along world +y (into the part)
    ENSURE_NEAR(out.force[1], 1.0, 1e-15);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  acceleration_drives_modes();
  world_coordinates();
  return test::finish("test_frame");
}
