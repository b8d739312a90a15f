// Display side: snapshots and the reconstruction u = Phi q of the display surface, run at display
// rate on another thread than the tick. The reconstruction streams the whole DISPLAY_MODES array
// once, so its speed is bounded by memory bandwidth; each vertex's 3 x r block is three vectorized
// dot products (dense.h), in one pass for short rows, one row after the other for long rows.
#include "display.h"

#include "dense.h"
#include "kernel.h"

#include <mrt/patch_profile.h>

#include <algorithm>
#include <cmath>

// The kernel is compiled for the baseline of its architecture (on x86-64: SSE2, 4 floats a vector),
// so that one binary runs on every machine. Where the modes sit in the caches (small surfaces, few
// modes) the reconstruction is bound by the arithmetic, not the memory; there, on x86-64 CPUs with
// AVX2 and FMA (checked once), it runs a copy compiled for them, whose short rows take 8 floats a
// step, their tails by masked loads, and reduce a vertex's three sums together (the compiler's
// reductions cost as much as the products on rows of 50). The display's sums then differ in the last
// bits between CPUs; the tick's (and so the session hash) do not. docs/performance.md has the figures.
#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(__AVX2__)
#define MODALRT_AVX2_COPY 1
#define MODALRT_AVX2 __attribute__((target("avx2,fma")))
#include <immintrin.h>
#endif

namespace modalrt
{
  namespace
  {
    // Long rows (r * sizeof(Scalar) > 256 bytes): the three rows of a block one after the other,
    // so that the array is read as one sequential stream. One pass over the three rows (dot_rows3,
    // which loads q once) reads three streams r apart, which the hardware prefetchers follow worse:
    // 2-3x slower at r = 200 once the array is out of the caches. Short rows lie within a few cache
    // lines of each other, and there the single pass is up to 40 % faster (less loop and reduction
    // overhead). Both give the same sums in the same order; q stays in L1 either way.
    template <typename Scalar>
    bool long_rows(const std::uint32_t r)
    {
      return r * sizeof(Scalar) > 256;
    }

    template <typename Scalar, typename Out>
    inline void vertex_displacements(const Scalar *block, const Scalar *q, std::uint32_t r, Out *o)
    {
      Scalar u[3];
      if (long_rows<Scalar>(r))
        for (std::uint32_t c = 0; c < 3; ++c)
          u[c] = dot_in_scalar(block + c * std::size_t(r), q, r);
      else
        dot_rows3(block, q, r, u);
      for (std::uint32_t c = 0; c < 3; ++c)
        o[c] = Out(u[c]);
    }

    template <typename Scalar, typename Out>
    void modal_displacements(const Scalar *modes, const Scalar *q, std::uint32_t r, std::uint32_t begin,
                             std::uint32_t end, Out *out)
    {
      for (std::uint32_t v = begin; v < end; ++v)
        vertex_displacements(modes + std::size_t(v) * 3 * r, q, r, out + 3 * std::size_t(v - begin));
    }

#ifdef MODALRT_AVX2_COPY
    bool cpu_has_avx2_fma()
    {
      static const bool has = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
      }();
      return has;
    }

    // The AVX2 operations of rows3_avx2, on 8 floats or 4 doubles.
    template <typename Scalar>
    struct Avx2;

    template <>
    struct Avx2<float>
    {
      using Vector                         = __m256;
      static constexpr std::uint32_t width = 8;
      MODALRT_AVX2 static Vector zero() { return _mm256_setzero_ps(); }
      MODALRT_AVX2 static Vector fmadd(Vector a, Vector b, Vector c) { return _mm256_fmadd_ps(a, b, c); }
      MODALRT_AVX2 static Vector load(const float *p) { return _mm256_loadu_ps(p); }
      // The first n < 8 values at p, then zeros: masked-off lanes are not read (no fault past the array).
      MODALRT_AVX2 static __m256i first(std::uint32_t n)
      {
        return _mm256_cmpgt_epi32(_mm256_set1_epi32(int(n)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      }
      MODALRT_AVX2 static Vector load(const float *p, __m256i lanes) { return _mm256_maskload_ps(p, lanes); }
      // The lane sums of s0, s1, s2: hadd(hadd(s0, s1), hadd(s2, s2)) has them in each 128-bit half.
      MODALRT_AVX2 static void sums(Vector s0, Vector s1, Vector s2, float u[3])
      {
        const __m256 quads = _mm256_hadd_ps(_mm256_hadd_ps(s0, s1), _mm256_hadd_ps(s2, s2));
        const __m128 sum   = _mm_add_ps(_mm256_castps256_ps128(quads), _mm256_extractf128_ps(quads, 1));
        u[0]               = _mm_cvtss_f32(sum);
        u[1]               = _mm_cvtss_f32(_mm_shuffle_ps(sum, sum, 1));
        u[2]               = _mm_cvtss_f32(_mm_shuffle_ps(sum, sum, 2));
      }
    };

    template <>
    struct Avx2<double>
    {
      using Vector                         = __m256d;
      static constexpr std::uint32_t width = 4;
      MODALRT_AVX2 static Vector zero() { return _mm256_setzero_pd(); }
      MODALRT_AVX2 static Vector fmadd(Vector a, Vector b, Vector c) { return _mm256_fmadd_pd(a, b, c); }
      MODALRT_AVX2 static Vector load(const double *p) { return _mm256_loadu_pd(p); }
      MODALRT_AVX2 static __m256i first(std::uint32_t n)
      {
        return _mm256_cmpgt_epi64(_mm256_set1_epi64x(n), _mm256_setr_epi64x(0, 1, 2, 3));
      }
      MODALRT_AVX2 static Vector load(const double *p, __m256i lanes) { return _mm256_maskload_pd(p, lanes); }
      // hadd(s0, s1) has the pair sums of s0 and s1 in each 128-bit half; s2 alone.
      MODALRT_AVX2 static void sums(Vector s0, Vector s1, Vector s2, double u[3])
      {
        const __m256d pairs01 = _mm256_hadd_pd(s0, s1), pairs2 = _mm256_hadd_pd(s2, s2);
        const __m128d sum01   = _mm_add_pd(_mm256_castpd256_pd128(pairs01), _mm256_extractf128_pd(pairs01, 1));
        const __m128d sum2    = _mm_add_pd(_mm256_castpd256_pd128(pairs2), _mm256_extractf128_pd(pairs2, 1));
        u[0]                  = _mm_cvtsd_f64(sum01);
        u[1]                  = _mm_cvtsd_f64(_mm_unpackhi_pd(sum01, sum01));
        u[2]                  = _mm_cvtsd_f64(sum2);
      }
    };

    // u[c] = sum_i block[c r + i] q[i], c = 0, 1, 2 (short rows): a vector of each row a step, the
    // tail by a masked load, the three sums reduced together.
    template <typename Scalar>
    MODALRT_AVX2 inline void rows3_avx2(const Scalar *block, const Scalar *q, std::uint32_t r, Scalar u[3])
    {
      using V                = Avx2<Scalar>;
      const Scalar      *row1 = block + r, *row2 = block + 2 * std::size_t(r);
      typename V::Vector s0 = V::zero(), s1 = s0, s2 = s0;
      std::uint32_t      i  = 0;
      for (; i + V::width <= r; i += V::width)
        {
          const auto x = V::load(q + i);
          s0           = V::fmadd(V::load(block + i), x, s0);
          s1           = V::fmadd(V::load(row1 + i), x, s1);
          s2           = V::fmadd(V::load(row2 + i), x, s2);
        }
      if (i < r)
        {
          const __m256i tail = V::first(r - i);
          const auto    x    = V::load(q + i, tail);
          s0                 = V::fmadd(V::load(block + i, tail), x, s0);
          s1                 = V::fmadd(V::load(row1 + i, tail), x, s1);
          s2                 = V::fmadd(V::load(row2 + i, tail), x, s2);
        }
      V::sums(s0, s1, s2, u);
    }

    // modal_displacements compiled for AVX2: its long rows by the same loops (vectorized 8 floats
    // wide here), its short rows by rows3_avx2.
    template <typename Scalar, typename Out>
    MODALRT_AVX2 void modal_displacements_avx2(const Scalar *modes, const Scalar *q, std::uint32_t r,
                                               std::uint32_t begin, std::uint32_t end, Out *out)
    {
      const bool long_block = long_rows<Scalar>(r);
      for (std::uint32_t v = begin; v < end; ++v)
        {
          const Scalar *block = modes + std::size_t(v) * 3 * r;
          Out          *o     = out + 3 * std::size_t(v - begin);
          if (long_block)
            vertex_displacements(block, q, r, o);
          else
            {
              Scalar u[3];
              rows3_avx2(block, q, r, u);
              for (std::uint32_t c = 0; c < 3; ++c)
                o[c] = Out(u[c]);
            }
        }
    }
#endif

    // The reconstruction of vertices begin to end: the AVX2 copy where the CPU has it.
    template <typename Scalar, typename Out>
    void displacements(const Scalar *modes, const Scalar *q, std::uint32_t r, std::uint32_t begin,
                       std::uint32_t end, Out *out)
    {
#ifdef MODALRT_AVX2_COPY
      if (cpu_has_avx2_fma())
        return modal_displacements_avx2(modes, q, r, begin, end, out);
#endif
      modal_displacements(modes, q, r, begin, end, out);
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
                  weight = mrt::patch_profile(std::sqrt(d2) / rho);
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
      displacements(space.display_modes_f64.data(), s.q.data(), r, begin, end, out);
    else
      displacements(space.display_modes_f32.data(), snapshot.q_f32.data(), r, begin, end, out);
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
