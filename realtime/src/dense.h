// The dot products of the hot loops (tick rows B q, display blocks Phi_v q), and a small dense solve.
//
// A plain `sum += a[i] * b[i]` loop is a chain of dependent additions that compilers may not
// reorder without -ffast-math, so it runs at one addition per add-latency (4 cycles). The
// `omp simd reduction` pragma allows reordering for these loops only (vector lanes, partial sums);
// the build passes -fopenmp-simd, which honours the pragma without any OpenMP runtime. The order of
// the partial sums is fixed by the build, so results are reproducible run to run.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>

// A function the compiler must keep as one out-of-line copy (the same instructions, so the same
// order of a vectorized reduction's partial sums, wherever it is called).
#if defined(__GNUC__)
#define MODALRT_NOINLINE __attribute__((noinline))
#elif defined(_MSC_VER)
#define MODALRT_NOINLINE __declspec(noinline)
#else
#define MODALRT_NOINLINE
#endif

namespace modalrt
{
  template <typename A, typename B>
  inline double dot(const A *a, const B *b, std::uint32_t n)
  {
    double sum = 0.0;
#pragma omp simd reduction(+ : sum)
    for (std::uint32_t i = 0; i < n; ++i)
      sum += double(a[i]) * double(b[i]);
    return sum;
  }

  // M += B_a G B_b^T and N += B_a H B_b^T over modes [first, last) (a, b: 3 x r rows; G = diag(g1),
  // H = diag(g2)).
  inline void add_pair_gram(const double *a, const double *b, const double *g1, const double *g2, std::uint32_t r,
                     std::uint32_t first, std::uint32_t last, double M[9], double N[9])
  {
    const double *a0 = a, *a1 = a + r, *a2 = a + 2 * std::size_t(r), *b0 = b, *b1 = b + r, *b2 = b + 2 * std::size_t(r);
    for (int half = 0; half < 2; ++half)
      {
        const double *g   = half == 0 ? g1 : g2;
        double       *out = half == 0 ? M : N;
        double        s00 = 0, s01 = 0, s02 = 0, s10 = 0, s11 = 0, s12 = 0, s20 = 0, s21 = 0, s22 = 0;
#pragma omp simd reduction(+ : s00, s01, s02, s10, s11, s12, s20, s21, s22)
        for (std::uint32_t i = first; i < last; ++i)
          {
            const double x0 = g[i] * a0[i], x1 = g[i] * a1[i], x2 = g[i] * a2[i];
            s00 += x0 * b0[i], s01 += x0 * b1[i], s02 += x0 * b2[i];
            s10 += x1 * b0[i], s11 += x1 * b1[i], s12 += x1 * b2[i];
            s20 += x2 * b0[i], s21 += x2 * b1[i], s22 += x2 * b2[i];
          }
        const double sum[9] = {s00, s01, s02, s10, s11, s12, s20, s21, s22};
        for (int e = 0; e < 9; ++e)
          out[e] += sum[e];
      }
  }

  // The same for b = a: six sums, mirrored (the block is symmetric to the last bit).
  inline void add_own_gram(const double *a, const double *g1, const double *g2, std::uint32_t r, std::uint32_t first,
                           std::uint32_t last, double M[9], double N[9])
  {
    const double *a0 = a, *a1 = a + r, *a2 = a + 2 * std::size_t(r);
    for (int half = 0; half < 2; ++half)
      {
        const double *g   = half == 0 ? g1 : g2;
        double       *out = half == 0 ? M : N;
        double        s00 = 0, s01 = 0, s02 = 0, s11 = 0, s12 = 0, s22 = 0;
#pragma omp simd reduction(+ : s00, s01, s02, s11, s12, s22)
        for (std::uint32_t i = first; i < last; ++i)
          {
            const double x0 = g[i] * a0[i], x1 = g[i] * a1[i];
            s00 += x0 * a0[i], s01 += x0 * a1[i], s02 += x0 * a2[i];
            s11 += x1 * a1[i], s12 += x1 * a2[i], s22 += g[i] * a2[i] * a2[i];
          }
        const double sum[9] = {s00, s01, s02, s01, s11, s12, s02, s12, s22};
        for (int e = 0; e < 9; ++e)
          out[e] += sum[e];
      }
  }

  // Asks for `bytes` from `data` on to be brought into the cache (a hint; nothing where the compiler
  // has no prefetch instruction).
  inline void prefetch(const void *data, std::size_t bytes)
  {
#if defined(__GNUC__)
    for (std::size_t offset = 0; offset < bytes; offset += 64)
      __builtin_prefetch(static_cast<const char *>(data) + offset);
#else
    (void)data, (void)bytes;
#endif
  }

  // Two dot products sharing their first vector, in one pass over it: (a . x, a . y).
  inline void dot_pair(const double *a, const double *x, const double *y, std::uint32_t n, double &ax, double &ay)
  {
    double sx = 0.0, sy = 0.0;
#pragma omp simd reduction(+ : sx, sy)
    for (std::uint32_t i = 0; i < n; ++i)
      {
        sx += a[i] * x[i];
        sy += a[i] * y[i];
      }
    ax = sx;
    ay = sy;
  }

  // a . b summed in the type of the operands (float modes keep float sums, as dot_rows3 does).
  template <typename Scalar>
  inline Scalar dot_in_scalar(const Scalar *a, const Scalar *b, std::uint32_t n)
  {
    Scalar sum = 0;
#pragma omp simd reduction(+ : sum)
    for (std::uint32_t i = 0; i < n; ++i)
      sum += a[i] * b[i];
    return sum;
  }

  // u[c] = sum_i block[c n + i] q[i], c = 0, 1, 2: a 3 x n row-major block times a vector, the three
  // rows in one pass so that q is loaded once.
  template <typename Scalar, typename Result>
  inline void dot_rows3(const Scalar *block, const Scalar *q, std::uint32_t n, Result u[3])
  {
    const Scalar *row1 = block + n, *row2 = block + 2 * std::size_t(n);
    Scalar        s0 = 0, s1 = 0, s2 = 0;
#pragma omp simd reduction(+ : s0, s1, s2)
    for (std::uint32_t i = 0; i < n; ++i)
      {
        s0 += block[i] * q[i];
        s1 += row1[i] * q[i];
        s2 += row2[i] * q[i];
      }
    u[0] = Result(s0);
    u[1] = Result(s1);
    u[2] = Result(s2);
  }
  // u = B x and w = B y for a 3 x n row-major block B, in one pass over B (positions and velocities
  // of a contact read its row block once).
  inline void dot_rows3_pair(const double *block, const double *x, const double *y, std::uint32_t n, double u[3],
                             double w[3])
  {
    const double *row1 = block + n, *row2 = block + 2 * std::size_t(n);
    double        u0 = 0, u1 = 0, u2 = 0, w0 = 0, w1 = 0, w2 = 0;
#pragma omp simd reduction(+ : u0, u1, u2, w0, w1, w2)
    for (std::uint32_t i = 0; i < n; ++i)
      {
        u0 += block[i] * x[i];
        u1 += row1[i] * x[i];
        u2 += row2[i] * x[i];
        w0 += block[i] * y[i];
        w1 += row1[i] * y[i];
        w2 += row2[i] * y[i];
      }
    u[0] = u0, u[1] = u1, u[2] = u2;
    w[0] = w0, w[1] = w1, w[2] = w2;
  }

  // u_k = B_k x for three 3 x n row-major blocks (k = 0, 1, 2, into u[3 k + c]) and w = C y for a
  // fourth, in one pass over x and y: a sliding contact's corners' displacements and its load
  // point's velocity.
  inline void dot_corners_pair(const double *b0, const double *b1, const double *b2, const double *c, const double *x,
                               const double *y, std::uint32_t n, double u[9], double w[3])
  {
    const std::size_t m = n;
    double            s0 = 0, s1 = 0, s2 = 0, s3 = 0, s4 = 0, s5 = 0, s6 = 0, s7 = 0, s8 = 0, w0 = 0, w1 = 0, w2 = 0;
#pragma omp simd reduction(+ : s0, s1, s2, s3, s4, s5, s6, s7, s8, w0, w1, w2)
    for (std::uint32_t i = 0; i < n; ++i)
      {
        const double xi = x[i], yi = y[i];
        s0 += b0[i] * xi, s1 += b0[m + i] * xi, s2 += b0[2 * m + i] * xi;
        s3 += b1[i] * xi, s4 += b1[m + i] * xi, s5 += b1[2 * m + i] * xi;
        s6 += b2[i] * xi, s7 += b2[m + i] * xi, s8 += b2[2 * m + i] * xi;
        w0 += c[i] * yi, w1 += c[m + i] * yi, w2 += c[2 * m + i] * yi;
      }
    u[0] = s0, u[1] = s1, u[2] = s2, u[3] = s3, u[4] = s4, u[5] = s5, u[6] = s6, u[7] = s7, u[8] = s8;
    w[0] = w0, w[1] = w1, w[2] = w2;
  }

  // A x = b for a small dense n x n row-major A, by Gaussian elimination with partial pivoting; A is
  // destroyed and the solution is written over b. False (b partly eliminated) on a vanishing pivot.
  inline bool solve_in_place(double *A, double *b, std::uint32_t n) noexcept
  {
    for (std::uint32_t k = 0; k < n; ++k)
      {
        std::uint32_t pivot = k;
        for (std::uint32_t i = k + 1; i < n; ++i)
          if (std::fabs(A[i * n + k]) > std::fabs(A[pivot * n + k]))
            pivot = i;
        if (!(std::fabs(A[pivot * n + k]) > 1e-300))
          return false;
        if (pivot != k)
          {
            for (std::uint32_t j = 0; j < n; ++j)
              std::swap(A[k * n + j], A[pivot * n + j]);
            std::swap(b[k], b[pivot]);
          }
        for (std::uint32_t i = k + 1; i < n; ++i)
          {
            const double factor = A[i * n + k] / A[k * n + k];
            for (std::uint32_t j = k; j < n; ++j)
              A[i * n + j] -= factor * A[k * n + j];
            b[i] -= factor * b[k];
          }
      }
    for (std::uint32_t k = n; k-- > 0;)
      {
        double sum = b[k];
        for (std::uint32_t j = k + 1; j < n; ++j)
          sum -= A[k * n + j] * b[j];
        b[k] = sum / A[k * n + k];
      }
    return true;
  }
} // namespace modalrt
