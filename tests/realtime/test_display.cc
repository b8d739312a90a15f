// Display: snapshots published by the tick and the reconstruction u = Phi q (float32 and float64
// modes), the static correction drawn at the contact, world positions, split ranges, and a display
// thread reading while the tick runs (every snapshot it sees is one the tick published, whole).
#include "test_support.h"

#include <atomic>
#include <thread>

using modalrt::BasisContent;
using modalrt::LatticeOptions;

namespace
{
  // Pushes the tip for a while so that the state is not trivial; returns the kernel.
  modalrt_kernel *pushed_kernel(const modalrt_basis *b, std::uint32_t vertex, int ticks)
  {
    modalrt_kernel    *k  = test::create(b, modalrt_kernel_default_def());
    modalrt_hip_input  in = test::hip_at(modalrt_basis_display_vertices(b) + 3 * vertex, 0.2, 0.1, -1.0);
    modalrt_hip_output out;
    modalrt_kernel_contact_begin(k, 0, vertex);
    for (int n = 0; n < ticks; ++n)
      modalrt_kernel_tick_admittance(k, &in, 1, &out);
    return k;
  }

  // r_tip modes in the tip space: row lengths around the kernel's vector widths (4 doubles, 8
  // floats on AVX2) and its short/long row threshold (32 doubles, 64 floats) test the tails.
  void reconstruction_matches_modes(bool float64, std::uint32_t r_tip)
  {
    LatticeOptions o;
    o.float64_modes       = float64;
    o.modes               = {8, r_tip};
    const BasisContent c  = modalrt::make_lattice_cantilever(o);
    modalrt_basis     *b  = test::load(c);
    modalrt_kernel    *k  = pushed_kernel(b, modalrt::lattice_display_vertex(o, 8, 1), 37);
    modalrt_snapshot  *s  = nullptr;
    ENSURE(modalrt_snapshot_create(k, &s) == MODALRT_OK);
    ENSURE(modalrt_kernel_snapshot_read(k, s) == 1);
    ENSURE(modalrt_kernel_snapshot_read(k, s) == 0); // nothing newer

    modalrt_snapshot_info info;
    modalrt_snapshot_get_info(s, &info);
    std::vector<double> q(256);
    std::uint32_t       r;
    modalrt_kernel_get_modal_state(k, q.data(), nullptr, 256, &r);
    ENSURE(info.tick == 37 && info.space == 1 && info.mode_count == r && r == r_tip && info.contact_count == 1);
    ENSURE(std::equal(q.begin(), q.begin() + r, modalrt_snapshot_modal_coordinates(s)));

    const std::uint32_t nv = c.vertex_count();
    std::vector<double> u(3 * nv);
    std::vector<float>  uf(3 * nv);
    ENSURE(modalrt_display_reconstruct_f64(s, 0, nv, MODALRT_DISPLAY_NO_CORRECTION, u.data()) == MODALRT_OK);
    ENSURE(modalrt_display_reconstruct(s, 0, nv, MODALRT_DISPLAY_NO_CORRECTION, uf.data()) == MODALRT_OK);
    const auto &modes = c.spaces[1].display_modes;
    double      scale = 0.0, worst = 0.0, worst_f = 0.0;
    for (std::size_t row = 0; row < 3 * std::size_t(nv); ++row)
      {
        double expected = 0.0;
        for (std::uint32_t i = 0; i < r; ++i)
          expected += (float64 ? modes[row * r + i] : double(float(modes[row * r + i]))) * q[i];
        scale   = std::max(scale, std::fabs(expected));
        worst   = std::max(worst, std::fabs(u[row] - expected));
        worst_f = std::max(worst_f, std::fabs(double(uf[row]) - expected));
      }
    ENSURE(scale > 0.0);
    ENSURE(worst <= (float64 ? 1e-14 : 1e-6) * scale);
    ENSURE(worst_f <= 1e-6 * scale);

    // Split ranges give the same numbers as one call.
    std::vector<double> halves(3 * nv);
    modalrt_display_reconstruct_f64(s, 0, nv / 2, MODALRT_DISPLAY_NO_CORRECTION, halves.data());
    modalrt_display_reconstruct_f64(s, nv / 2, nv, MODALRT_DISPLAY_NO_CORRECTION, halves.data() + 3 * (nv / 2));
    ENSURE(halves == u);
    ENSURE(modalrt_display_reconstruct_f64(s, 0, nv + 1, 0, u.data()) == MODALRT_ERROR_INVALID_ARGUMENT);
    modalrt_snapshot_destroy(s);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // With rho = 0 the drawn active vertex (modes + correction) is exactly where the HIP feels it.
  void correction_drawn_at_contact()
  {
    LatticeOptions o;
    const BasisContent  c = modalrt::make_lattice_cantilever(o);
    modalrt_basis      *b = test::load(c);
    const std::uint32_t v = modalrt::lattice_display_vertex(o, 6, 2);
    modalrt_kernel     *k = pushed_kernel(b, v, 50);
    modalrt_hip_input   in = test::hip_at(modalrt_basis_display_vertices(b) + 3 * v, 0.2, 0.1, -1.0);
    modalrt_hip_output  out;
    modalrt_kernel_tick_admittance(k, &in, 1, &out);
    modalrt_snapshot *s = nullptr;
    modalrt_snapshot_create(k, &s);
    modalrt_kernel_snapshot_read(k, s);
    double drawn[3], modal[3];
    modalrt_display_reconstruct_f64(s, v, v + 1, MODALRT_DISPLAY_POSITIONS, drawn);
    modalrt_display_reconstruct_f64(s, v, v + 1, MODALRT_DISPLAY_NO_CORRECTION, modal);
    for (int d = 0; d < 3; ++d)
      ENSURE_NEAR(drawn[d], out.position[d], 1e-15);
    const double *x = modalrt_basis_display_vertices(b) + 3 * v;
    ENSURE(std::fabs(drawn[2] - x[2] - modal[2]) > 0.0); // the correction is there
    modalrt_snapshot_destroy(s);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  void world_positions()
  {
    modalrt_basis      *b = test::load(modalrt::make_lattice_cantilever());
    modalrt_kernel     *k = test::create(b, modalrt_kernel_default_def());
    modalrt_frame_state f = modalrt_frame_state_identity();
    f.position[0]         = 1.0;
    f.position[2]         = 0.5;
    f.orientation[0]      = std::sqrt(0.5); // 90 degrees about z
    f.orientation[3]      = std::sqrt(0.5);
    ENSURE(modalrt_kernel_set_frame(k, &f) == MODALRT_OK);
    modalrt_hip_output out;
    modalrt_kernel_tick_admittance(k, nullptr, 0, &out);
    modalrt_snapshot *s = nullptr;
    modalrt_snapshot_create(k, &s);
    modalrt_kernel_snapshot_read(k, s);
    double p[3];
    modalrt_display_reconstruct_f64(s, 5, 6, MODALRT_DISPLAY_POSITIONS | MODALRT_DISPLAY_WORLD, p);
    const double *x = modalrt_basis_display_vertices(b) + 15;
    ENSURE_NEAR(p[0], 1.0 - x[1], 1e-15);
    ENSURE_NEAR(p[1], x[0], 1e-15);
    ENSURE_NEAR(p[2], 0.5 + x[2], 1e-15);
    modalrt_snapshot_destroy(s);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // The tick thread records q after every tick; the display thread records what it reads. Every
  // read must equal the state of the tick it claims, bit for bit: no torn snapshot.
  void concurrent_reader()
  {
    LatticeOptions o;
    modalrt_basis      *b = test::load(modalrt::make_lattice_cantilever(o));
    modalrt_kernel     *k = test::create(b, modalrt_kernel_default_def());
    const std::uint32_t v = modalrt::lattice_display_vertex(o, 8, 1);
    modalrt_kernel_contact_begin(k, 0, v);
    const int                        ticks = 200000; // at most: stops once the reader has seen enough
    const std::uint32_t              r     = 16;
    std::vector<double>              history(std::size_t(ticks + 1) * r, 0.0);
    std::atomic<bool>                done{false};
    std::atomic<std::size_t>         seen_size{0};
    auto seen_count = [](const std::atomic<std::size_t> &c) { return c.load(); };
    std::vector<std::pair<std::uint64_t, std::vector<double>>> seen;
    seen.reserve(200000);
    modalrt_snapshot *s = nullptr;
    modalrt_snapshot_create(k, &s);
    std::vector<float> positions(3 * 27);

    std::thread display([&] {
      while (!done.load())
        if (modalrt_kernel_snapshot_read(k, s) == 1)
          {
            modalrt_snapshot_info info;
            modalrt_snapshot_get_info(s, &info);
            modalrt_display_reconstruct(s, 0, 27, MODALRT_DISPLAY_POSITIONS, positions.data());
            const double *q = modalrt_snapshot_modal_coordinates(s);
            if (seen.size() < seen.capacity())
              {
                seen.push_back({info.tick, std::vector<double>(q, q + info.mode_count)});
                seen_size = seen.size();
              }
          }
    });
    modalrt_hip_input  in = test::hip_at(modalrt_basis_display_vertices(b) + 3 * v);
    modalrt_hip_output out;
    std::atomic<std::size_t> reads{0};
    int                      n = 1;
    for (; n <= ticks && (n <= 20000 || seen_count(reads) < 200); ++n)
      {
        in.force[2] = -std::sin(0.01 * n);
        modalrt_kernel_tick_admittance(k, &in, 1, &out);
        modalrt_kernel_get_modal_state(k, &history[std::size_t(n) * r], nullptr, r, nullptr);
        if (n % 100 == 0)
          {
            reads = seen_size.load();
            std::this_thread::yield(); // the machine may be busy: let the display thread in
          }
      }
    done = true;
    display.join();

    std::size_t   mismatches = 0;
    std::uint64_t last       = 0;
    bool          monotonic  = true;
    for (const auto &entry : seen)
      {
        monotonic = monotonic && entry.first > last;
        last      = entry.first;
        if (entry.second.size() != r || !std::equal(entry.second.begin(), entry.second.end(), &history[entry.first * r]))
          ++mismatches;
      }
    std::printf("  display thread read %zu snapshots over %d ticks, %zu torn\n", seen.size(), n - 1, mismatches);
    ENSURE(!seen.empty() && mismatches == 0 && monotonic);
    modalrt_snapshot_destroy(s);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  for (const std::uint32_t r : {1u, 3u, 4u, 5u, 7u, 8u, 9u, 16u, 31u, 32u, 33u, 50u, 63u, 64u, 65u, 70u})
    {
      reconstruction_matches_modes(true, r);
      reconstruction_matches_modes(false, r);
    }
  correction_drawn_at_contact();
  world_positions();
  concurrent_reader();
  return test::finish("test_display");
}
