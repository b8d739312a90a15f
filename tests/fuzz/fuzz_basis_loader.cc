// libFuzzer harness of the .mrt reader (docs/basis-format.md), built by tests/fuzz/CMakeLists.txt
// with clang -fsanitize=fuzzer,address,undefined and run by scripts/test-kernel-checks.
//
// The reader's promise is that a file it accepts never makes the kernel index out of range or meet
// a number that is not finite, and that a file it refuses fails cleanly. So each input is loaded
// with modalrt_basis_load_memory and, when it loads, driven through everything a user does with a
// basis: the info queries, every array the API hands out (read to its documented length, so that
// AddressSanitizer sees a short array), the self-check, and a kernel with the default definition
// running admittance and impedance ticks, a contact, space switches, a moving frame, and a display
// snapshot reconstructed over the whole surface.
//
// Every section carries a CRC-32, so almost every random mutation is refused at its first checksum
// and never reaches the checks behind it. Each input is therefore loaded twice: as is (the
// checksum paths), and, when that changes anything, with every CRC recomputed (the layout, count,
// index and value checks, and the kernel behind them).
#include <modalrt/modalrt.h>
#include <mrt/format.h>
#include <mrt/writer.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace
{
  // A broken promise of the API is a finding: report it and abort, so libFuzzer keeps the input.
  void expect(bool condition, const char *what)
  {
    if (!condition)
      {
        std::fprintf(stderr, "fuzz_basis_loader: broken expectation: %s\n", what);
        std::abort();
      }
  }

  // Where touch() leaves its sum: a volatile store the optimizer must keep, and with it the loads
  // that AddressSanitizer checks (ASan instruments after optimization, so unused loads go unchecked).
  volatile double sink = 0.0;

  // Reads the n values of an array the API hands out.
  template <typename T>
  void touch(const T *values, std::size_t n)
  {
    expect(n == 0 || values != nullptr, "an array of the basis is missing");
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      sum += double(values[i]);
    sink = sum;
  }

  // A few ticks of a kernel with the default definition: a HIP pressed into vertex 0 along its
  // normal and a second one into the first candidate of the last space (a switch at contact start
  // and a static correction), admittance then impedance; a third HIP on the last vertex through the
  // explicit contact call; the state carried into each space; a moving frame; and the display
  // snapshot of the result.
  void drive_kernel(const modalrt_basis *basis, const modalrt_basis_info &info)
  {
    const modalrt_kernel_def def    = modalrt_kernel_default_def();
    modalrt_kernel          *kernel = nullptr;
    const int                status = modalrt_kernel_create(basis, &def, &kernel);
    if (status != MODALRT_OK)
      {
        expect(status < 0 && kernel == nullptr, "a failed kernel_create returned a kernel");
        return;
      }

    const double  *x = modalrt_basis_display_vertices(basis);
    const double  *n = modalrt_basis_display_normals(basis);
    modalrt_space_info last_space;
    modalrt_basis_get_space_info(basis, info.space_count - 1, &last_space);
    const std::uint32_t pressed[2] = {0, last_space.candidate_count > 0
                                           ? modalrt_basis_candidates(basis, info.space_count - 1)[0]
                                           : info.display_vertex_count / 2};
    modalrt_hip_input  inputs[3]  = {};
    modalrt_hip_output outputs[3] = {};
    for (int h = 0; h < 2; ++h)
      for (int d = 0; d < 3; ++d)
        {
          const std::size_t v   = pressed[h];
          inputs[h].position[d] = x[3 * v + d] - 1e-4 * n[3 * v + d]; // just inside the surface
          inputs[h].force[d]    = -0.5 * n[3 * v + d];               // pushing inward
        }
    for (int d = 0; d < 3; ++d)
      inputs[2].position[d] = x[3 * std::size_t(info.display_vertex_count - 1) + d];
    for (int t = 0; t < 4; ++t)
      modalrt_kernel_tick_admittance(kernel, inputs, 2, outputs);
    for (int t = 0; t < 4; ++t)
      modalrt_kernel_tick_impedance(kernel, inputs, 2, outputs);

    modalrt_kernel_contact_begin(kernel, 2, info.display_vertex_count - 1);
    for (std::uint32_t s = 0; s < info.space_count && s < 8; ++s)
      {
        modalrt_kernel_switch_space(kernel, s);
        modalrt_kernel_tick_admittance(kernel, inputs, 3, outputs);
        modalrt_kernel_tick_impedance(kernel, inputs, 3, outputs);
      }

    // The frame's acceleration drives the modes through PARTICIPATION.
    modalrt_frame_state frame    = modalrt_frame_state_identity();
    frame.linear_acceleration[2] = -9.81;
    frame.angular_acceleration[0] = 2.0;
    modalrt_kernel_set_frame(kernel, &frame);
    modalrt_kernel_settle(kernel, inputs, 3);
    modalrt_kernel_tick_admittance(kernel, inputs, 3, outputs);
    modalrt_kernel_release_hip(kernel, 2);
    modalrt_kernel_tick_impedance(kernel, inputs, 3, outputs);

    modalrt_kernel_stats stats;
    expect(modalrt_kernel_get_stats(kernel, &stats) == MODALRT_OK, "kernel_get_stats failed");
    std::uint32_t mode_count = 0;
    expect(modalrt_kernel_get_modal_state(kernel, nullptr, nullptr, 0, &mode_count) == MODALRT_OK &&
             mode_count <= info.max_modes,
           "the active space has more modes than max_modes");
    std::vector<double> q(info.max_modes), v(info.max_modes);
    expect(modalrt_kernel_get_modal_state(kernel, q.data(), v.data(), info.max_modes, &mode_count) == MODALRT_OK,
           "kernel_get_modal_state failed with max_modes of room");

    modalrt_snapshot *snapshot = nullptr;
    if (modalrt_snapshot_create(kernel, &snapshot) == MODALRT_OK)
      {
        expect(modalrt_kernel_snapshot_read(kernel, snapshot) >= 0, "snapshot_read failed");
        modalrt_snapshot_info snapshot_info;
        modalrt_snapshot_get_info(snapshot, &snapshot_info);
        touch(modalrt_snapshot_modal_coordinates(snapshot), snapshot_info.mode_count);
        std::vector<float> positions(3 * std::size_t(info.display_vertex_count));
        modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count, MODALRT_DISPLAY_POSITIONS | MODALRT_DISPLAY_WORLD,
                                    positions.data());
        std::vector<double> displacements(3 * std::size_t(info.display_vertex_count));
        modalrt_display_reconstruct_f64(snapshot, 0, info.display_vertex_count, MODALRT_DISPLAY_DISPLACEMENTS,
                                        displacements.data());
        modalrt_snapshot_destroy(snapshot);
      }
    modalrt_kernel_destroy(kernel);
  }

  // One load and, if it succeeds, everything a user does with the basis.
  void exercise(const std::uint8_t *data, std::size_t size)
  {
    modalrt_basis *basis  = nullptr;
    const int      status = modalrt_basis_load_memory(data, size, &basis);
    if (status != MODALRT_OK)
      {
        // A refused file leaves no basis behind and says why.
        expect(status < 0 && basis == nullptr, "a failed load returned a basis or a non-error status");
        const char *message = modalrt_last_error_message();
        expect(message != nullptr && message[0] != '\0', "a failed load left no message");
        return;
      }

    modalrt_basis_info info;
    expect(modalrt_basis_get_info(basis, &info) == MODALRT_OK, "basis_get_info failed");
    expect(info.space_count >= 1 && info.display_vertex_count >= 1 && info.max_modes >= 1,
           "a loaded basis has no space, no vertex or no mode");
    expect(info.file_bytes == size, "file_bytes differs from the size loaded");

    const std::size_t nv = info.display_vertex_count, nt = info.display_triangle_count;
    touch(modalrt_basis_display_vertices(basis), 3 * nv);
    touch(modalrt_basis_display_normals(basis), 3 * nv);
    touch(modalrt_basis_display_regions(basis), nv);
    const std::uint32_t *triangles = modalrt_basis_display_triangles(basis);
    touch(triangles, 3 * nt);
    for (std::size_t k = 0; k < 3 * nt; ++k)
      expect(triangles[k] < nv, "a triangle of a loaded basis names a vertex out of range");

    for (std::uint32_t s = 0; s < info.space_count; ++s)
      {
        modalrt_space_info space;
        expect(modalrt_basis_get_space_info(basis, s, &space) == MODALRT_OK, "basis_get_space_info failed");
        expect(space.mode_count >= 1 && space.mode_count <= info.max_modes, "a space's r is outside 1 .. max_modes");
        expect(std::memchr(space.name, '\0', sizeof space.name) != nullptr, "a space name is not NUL-terminated");
        touch(modalrt_basis_eigenvalues(basis, s), space.mode_count);
        touch(modalrt_basis_damping_ratios(basis, s), space.mode_count);
        touch(modalrt_basis_candidates(basis, s), space.candidate_count);
        for (std::uint32_t from = 0; from < info.space_count && from < 64; ++from)
          modalrt_basis_has_transfer(basis, s, from);
      }
    modalrt_space_info past_space;
    expect(modalrt_basis_get_space_info(basis, info.space_count, &past_space) < 0, "a space past the end was accepted");

    for (std::uint32_t k = 0; k < info.section_count; ++k)
      {
        modalrt_section_info section;
        expect(modalrt_basis_get_section(basis, k, &section) == MODALRT_OK, "basis_get_section failed");
        expect(section.offset + section.bytes <= info.file_bytes, "a section runs past the end of the file");
      }
    modalrt_section_info past_end;
    expect(modalrt_basis_get_section(basis, info.section_count, &past_end) < 0, "a section past the end was accepted");

    // The self-check builds one kernel per validation case; a basis that fails it is still valid
    // input, only an error status without a message is wrong.
    modalrt_verify_report report;
    const int verified = modalrt_basis_verify(basis, &report);
    expect(verified == MODALRT_OK || (verified < 0 && modalrt_last_error_message()[0] != '\0'),
           "basis_verify failed without a message");

    drive_kernel(basis, info);
    modalrt_basis_destroy(basis);
  }
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
  exercise(data, size);
  if (size >= mrt::header_bytes)
    {
      std::vector<unsigned char> fixed(data, data + size);
      mrt::refresh_checksums(fixed); // bounds-checked: the table may point anywhere
      if (std::memcmp(fixed.data(), data, size) != 0)
        exercise(fixed.data(), fixed.size());
    }
  return 0;
}
