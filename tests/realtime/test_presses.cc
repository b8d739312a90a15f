// presses.csv's analysis (find_presses in realtime/tools/run_outputs.cc) on hand-made traces: the
// felt force is the push's real maximum, not a fail-safe plateau the kernel held above it under a
// jittery client, nor a force ramp of the kernel's own.
#include "test_support.h"

#include "run_outputs.h"
#include "slides.h"
#include "stiffness_map.h"

namespace
{
  const double coupling = 1000.0; // [N/m] the made-up contact's stiffness: displacement = force / it

  // One HIP pressing display vertex `vertex` of the lattice: a row every 10 ms, in contact at every
  // row, the force along the outward normal pushing the hand out (impedance) and the vertex moved in
  // by force / coupling. flags[k] are the MODALRT_HIP_* bits of row k.
  modalrt_tool::HapticResult press_trace(const modalrt_basis *basis, std::uint32_t vertex,
                                         const std::vector<double> &force, const std::vector<std::uint32_t> &flags)
  {
    const double *rest   = modalrt_basis_display_vertices(basis) + 3 * vertex;
    const double *normal = modalrt_basis_display_normals(basis) + 3 * vertex;
    modalrt_tool::HapticResult result;
    for (std::size_t k = 0; k < force.size(); ++k)
      {
        modalrt_tool::TraceSample s{};
        s.time = 0.01 * double(k);
        for (int c = 0; c < 3; ++c)
          {
            s.force[c]   = force[k] * normal[c];
            s.contact[c] = rest[c] - force[k] / coupling * normal[c];
            s.hip[c]     = s.contact[c];
          }
        s.in_contact    = 1;
        s.active_vertex = vertex;
        s.space         = 1;
        s.flags         = flags[k];
        result.trace.push_back(s);
      }
    return result;
  }

  // A push to 5 N, unloading to 4 N, then a fail-safe plateau held at 7 N (above the real maximum;
  // the last row of the hold is ramping back), then the rest of the unloading.
  void fail_safe_plateau(const modalrt_basis *basis)
  {
    const std::uint32_t        vertex = modalrt::lattice_display_vertex(modalrt::LatticeOptions(), 8, 1);
    const std::vector<double>  force  = {1, 2, 3, 4, 5, 4, 7, 7, 7, 6.5, 3, 2, 1};
    const std::uint32_t        held   = MODALRT_HIP_FAIL_SAFE, ramp = MODALRT_HIP_FORCE_RAMPING;
    const std::vector<std::uint32_t> flags = {0, 0, 0, 0, 0, 0, held, held, held, ramp, 0, 0, 0};
    const auto presses = modalrt_tool::find_presses(press_trace(basis, vertex, force, flags), 1, basis, true, 5);
    ENSURE(presses.size() == 1);
    if (presses.size() != 1)
      return;
    std::printf("felt %.3g N at %.3g s (the plateau held 7 N from 0.06 s)\n", presses[0].felt_force,
                presses[0].felt_time);
    ENSURE_NEAR(presses[0].felt_force, 5.0, 1e-12);
    ENSURE_NEAR(presses[0].felt_time, 0.04, 1e-12);
    ENSURE_NEAR(presses[0].felt_stiffness, coupling, 1e-6);
    // The same trace without the flags picks the plateau: what the flags are there for.
    const auto unflagged = modalrt_tool::find_presses(
      press_trace(basis, vertex, force, std::vector<std::uint32_t>(force.size(), 0)), 1, basis, true, 5);
    ENSURE(unflagged.size() == 1 && unflagged[0].felt_force == 7.0);
    // trace.csv shows which rows were left out: hip0_flags is 32 on the plateau, 64 on the ramp.
    std::string error;
    ENSURE(modalrt_tool::write_trace("presses_trace.csv", press_trace(basis, vertex, force, flags), 1, basis, true, 5, error));
    std::ifstream     file("presses_trace.csv");
    std::stringstream text;
    text << file.rdbuf();
    ENSURE(text.str().find("hip0_space,hip0_flags,hip0_triangle,hip0_w0,hip0_w1,hip0_w2,hip0_fn,hip0_ft,hip0_static_stiffness,hip0_felt_stiffness,hip0_beyond,hip0_validity_force,frame_x") != std::string::npos);
    const std::string row = ",1," + std::to_string(vertex) + ",1,";
    ENSURE(text.str().find(row + "32,") != std::string::npos && text.str().find(row + "64,") != std::string::npos);
    std::remove("presses_trace.csv");
  }

  // A press the kernel held throughout (fail-safe from its first row) still gets a row: its last.
  void held_throughout(const modalrt_basis *basis)
  {
    const std::vector<double>        force = {3, 3, 3};
    const std::vector<std::uint32_t> flags(3, MODALRT_HIP_FAIL_SAFE);
    const auto presses = modalrt_tool::find_presses(press_trace(basis, 8, force, flags), 1, basis, true, 5);
    ENSURE(presses.size() == 1 && presses[0].felt_force == 3.0 && presses[0].felt_time == 0.02);
  }
  // A press flagged MODALRT_HIP_BEYOND_VALIDITY on some rows, on a basis with a validity map (vertex
  // 15 of the tip space: F1, F5, F10 = 0.35, 1.75, 3.5 N): when it went beyond, at which force, and the
  // value at its point at the level asked; trace.csv's beyond and validity_force columns.
  void beyond_validity()
  {
    modalrt::LatticeOptions o;
    o.validity_force = true;
    const std::vector<unsigned char> bytes = modalrt::write_basis(modalrt::make_lattice_cantilever(o));
    modalrt_basis                   *basis = nullptr;
    ENSURE(modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis) == MODALRT_OK);
    if (!basis)
      return;
    ENSURE(modalrt_tool::has_validity_map(basis));
    const std::vector<double>        force = {1, 1.5, 2, 2.5, 2, 1.5, 1};
    const std::uint32_t              b     = MODALRT_HIP_BEYOND_VALIDITY;
    const std::vector<std::uint32_t> flags = {0, 0, b, b, b, 0, 0};
    const auto presses = modalrt_tool::find_presses(press_trace(basis, 15, force, flags), 1, basis, true, 5);
    ENSURE(presses.size() == 1);
    if (presses.size() == 1)
      {
        const modalrt_tool::Press &p = presses[0];
        ENSURE(p.beyond && p.beyond_time == 0.02 && p.beyond_force == 2.0 && p.max_force == 2.5);
        ENSURE_NEAR(p.validity_force, 1.75, 1e-15);
      }
    const auto at_one = modalrt_tool::find_presses(press_trace(basis, 15, force, {0, 0, 0, 0, 0, 0, 0}), 1, basis, true, 1);
    ENSURE(at_one.size() == 1 && !at_one[0].beyond && std::isnan(at_one[0].beyond_time));
    ENSURE_NEAR(at_one[0].validity_force, 0.35, 1e-15);
    std::string error;
    ENSURE(modalrt_tool::write_trace("validity_trace.csv", press_trace(basis, 15, force, flags), 1, basis, true, 10, error));
    const std::string text = test::read_text("validity_trace.csv");
    ENSURE(text.find(",1,3.5,0,0,0\n") != std::string::npos); // a flagged row: beyond 1, F10 3.5 N, the frame
    ENSURE(text.find(",0,3.5,0,0,0\n") != std::string::npos);
    std::remove("validity_trace.csv");
    // Without a map: no value, never beyond.
    const std::vector<unsigned char> plain = modalrt::write_basis(modalrt::make_lattice_cantilever());
    modalrt_basis                   *other = nullptr;
    ENSURE(modalrt_basis_load_memory(plain.data(), plain.size(), &other) == MODALRT_OK);
    ENSURE(!modalrt_tool::has_validity_map(other));
    const auto none = modalrt_tool::find_presses(press_trace(other, 15, force, std::vector<std::uint32_t>(7, 0)), 1, other, true, 5);
    ENSURE(none.size() == 1 && std::isnan(none[0].validity_force) && !none[0].beyond);
    modalrt_basis_destroy(other);
    modalrt_basis_destroy(basis);
  }

  // A proxy that slides less than min_slide_length is a press's creep: no slide, so the press it
  // belongs to stays one record; one that slides farther is a slide. Each moves 0.1 mm per tick.
  void creep_is_not_a_slide()
  {
    for (const int ticks : {5, 20})
      {
        modalrt_tool::SlideTracker tracker;
        tracker.reset(1, 8, true);
        const double       frame[3] = {0.0, 0.0, 0.0};
        modalrt_hip_input  in{};
        modalrt_hip_output out{};
        out.in_contact = 1;
        for (int k = 0; k <= ticks + 1; ++k)
          {
            out.position[0] = 1e-4 * std::min(k, ticks);
            out.flags       = k >= 1 && k <= ticks ? MODALRT_HIP_SLIDING : 0;
            tracker.observe(1e-3 * k, &in, &out, frame, nullptr);
          }
        const auto slides = tracker.finish();
        std::printf("  sliding over %.1f mm: %zu slide(s), %llu creep(s)\n", 0.1 * (ticks - 1), slides.size(),
                    (unsigned long long)tracker.creeps());
        ENSURE(slides.size() == (ticks == 5 ? 0u : 1u) && tracker.creeps() == (ticks == 5 ? 1u : 0u));
      }
  }
} // namespace

int main()
{
  const std::vector<unsigned char> bytes = modalrt::write_basis(modalrt::make_lattice_cantilever());
  modalrt_basis                   *basis = nullptr;
  ENSURE(modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis) == MODALRT_OK);
  if (basis)
    {
      fail_safe_plateau(basis);
      held_throughout(basis);
    }
  beyond_validity();
  creep_is_not_a_slide();
  modalrt_basis_destroy(basis);
  return test::finish("test_presses");
}
