// Display side: snapshots and the reconstruction u = Phi q of the display surface, run at display
// rate on another thread than the tick. The reconstruction streams the whole DISPLAY_MODES array
// once, so its speed is bounded by memory bandwidth; each vertex's 3 x r block is three vectorized
// dot products (dense.h), in one pass for short rows, one row after the other for long rows.
#include "display.h"

#include "dense.h"
#include "kernel.h"

#include <algorithm>
#include <cmath>

// The kernel is compiled for the baseline of its architecture (on x86-64: SSE2, 4 floats a vector),
// so that one binary runs on every machine. Where the modes sit in the caches (small surfaces, few
// modes) the reconstruction is bound by the arithmetic, not the memory: there GCC also compiles it
// for AVX2, which the loader picks when the CPU has it (target_clones, an ELF ifunc: no test per
// call; Clang 14 clones no templates). Not AVX-512: its 16-float vectors and their reductions were
// slower on rows of 50 (docs/performance.md). The display's sums then differ in the last bits
// between CPUs; the tick's (and so the session hash) do not.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__ELF__) && !defined(__AVX2__)
#define MODALRT_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#else
#define MODALRT_AVX2_CLONE
#endif

namespace modalrt
{
  namespace
  {
    template <typename Scalar, typename Out>
    MODALRT_AVX2_CLONE void modal_displacements(const Scalar *modes, const Scalar *q, std::uint32_t r, std::uint32_t begin,
                             std::uint32_t end, Out *out)
    {
      // Long rows (r * sizeof(Scalar) > 256 bytes): the three rows of a block one
      // after the other, so that the array is read as one sequential stream. One pass over the
      // three rows (dot_rows3, which loads q once) reads three streams r apart, which the hardware
      // prefetchers follow worse: 2-3x slower at r = 200 once the array is out of the caches. Short
      // rows lie within a few cache lines of each other, and there the single pass is up to 40 %
      // faster (less loop and reduction overhead). docs/performance.md has the measurements. Both
      // give the same sums in the same order; q stays in L1 either way.
      const bool long_rows = r * sizeof(Scalar) > 256;
      for (std::uint32_t v = begin; v < end; ++v)
        {
          const Scalar *block = modes + std::size_t(v) * 3 * r;
          Out          *o     = out + 3 * std::size_t(v - begin);
          Scalar        u[3];
          if (long_rows)
            for (std::uint32_t c = 0; c < 3; ++c)
              u[c] = dot_in_scalar(block + c * std::size_t(r), q, r);
          else
            dot_rows3(block, q, r, u);
          for (std::uint32_t c = 0; c < 3; ++c)
            o[c] = Out(u[c]);
        }
    }

    // Near each contact at a candidate, the felt static correction C F spread over the patch with
    // the profile of the patch weights (1 - (d/rho)^2)^2, equal to 1 at the active vertex.
    template <typename Out>
    void add_corrections(const modalrt_snapshot &snapshot, std::uint32_t begin, std::uint32_t end, Out *out)
    {
      const modalrt_basis         &basis = *snapshot.basis;
      const modalrt::SnapshotState &s     = snapshot.state;
      const double                 rho   = basis.patch_radius();
      for (std::uint32_t k = 0; k < s.contact_count; ++k)
        {
          const double *c = &s.contact_corrections[3 * std::size_t(k)];
          if (c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0)
            continue;
          const std::uint32_t v  = s.contact_vertices[k];
          const double       *xv = &basis.vertices[3 * std::size_t(v)];
          for (std::uint32_t e = basis.patch_offsets[v]; e < basis.patch_offsets[v + 1]; ++e)
            {
              const std::uint32_t j = basis.patch_vertices[e];
              if (j < begin || j >= end)
                continue;
              double weight = j == v ? 1.0 : 0.0;
              if (rho > 0.0)
                {
                  const double *xj = &basis.vertices[3 * std::size_t(j)];
                  const double  d2 = (xj[0] - xv[0]) * (xj[0] - xv[0]) + (xj[1] - xv[1]) * (xj[1] - xv[1]) +
                                    (xj[2] - xv[2]) * (xj[2] - xv[2]);
                  const double t = std::max(0.0, 1.0 - d2 / (rho * rho));
                  weight         = t * t;
                }
              Out *o = out + 3 * std::size_t(j - begin);
              for (int d = 0; d < 3; ++d)
                o[d] = Out(double(o[d]) + weight * c[d]);
            }
        }
    }

    template <typename Out>
    void to_positions(const modalrt_snapshot &snapshot, std::uint32_t begin, std::uint32_t end, bool world, Out *out)
    {
      const modalrt_basis         &basis = *snapshot.basis;
      const modalrt::SnapshotState &s     = snapshot.state;
      const double                *R     = s.frame_rotation;
      for (std::uint32_t v = begin; v < end; ++v)
        {
          Out         *o = out + 3 * std::size_t(v - begin);
          const double x[3] = {basis.vertices[3 * std::size_t(v)] + double(o[0]),
                               basis.vertices[3 * std::size_t(v) + 1] + double(o[1]),
                               basis.vertices[3 * std::size_t(v) + 2] + double(o[2])};
          for (int d = 0; d < 3; ++d)
            o[d] = world ? Out(s.frame_position[d] + R[3 * d] * x[0] + R[3 * d + 1] * x[1] + R[3 * d + 2] * x[2])
                         : Out(x[d]);
        }
    }
  } // namespace

  template <typename Out>
  int reconstruct(const modalrt_snapshot &snapshot, std::uint32_t begin, std::uint32_t end, std::uint32_t flags,
                  Out *out) noexcept
  {
    const modalrt_basis &basis = *snapshot.basis;
    if (begin > end || end > basis.vertex_count || (!out && end > begin))
      return MODALRT_ERROR_INVALID_ARGUMENT;
    const modalrt::SnapshotState &s = snapshot.state;
    const std::uint32_t           r = s.mode_count;
    const ModalSpace             &space = basis.spaces[s.space];
    if (basis.float64_modes())
      modal_displacements(space.display_modes_f64.data(), s.q.data(), r, begin, end, out);
    else
      modal_displacements(space.display_modes_f32.data(), snapshot.q_f32.data(), r, begin, end, out);
    if (!(flags & MODALRT_DISPLAY_NO_CORRECTION))
      add_corrections(snapshot, begin, end, out);
    if (flags & MODALRT_DISPLAY_POSITIONS)
      to_positions(snapshot, begin, end, (flags & MODALRT_DISPLAY_WORLD) != 0, out);
    return MODALRT_OK;
  }

  template int reconstruct<float>(const modalrt_snapshot &, std::uint32_t, std::uint32_t, std::uint32_t, float *) noexcept;
  template int reconstruct<double>(const modalrt_snapshot &, std::uint32_t, std::uint32_t, std::uint32_t,
                                   double *) noexcept;

  int read_snapshot(modalrt_kernel &kernel, modalrt_snapshot &snapshot) noexcept
  {
    bool                          fresh;
    const modalrt::SnapshotState &latest = kernel.snapshots.acquire(fresh);
    snapshot.state.copy_from(latest);
    for (std::uint32_t i = 0; i < snapshot.state.mode_count; ++i)
      snapshot.q_f32[i] = float(snapshot.state.q[i]);
    return fresh ? 1 : 0;
  }
} // namespace modalrt
