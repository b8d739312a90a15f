// The machine's limits for the eigensolver benchmark, measured in the same run as the solvers:
// the dense DGEMM rate of the BLAS the solvers use (OpenBLAS: its thread count from
// OPENBLAS_NUM_THREADS) and the memory read bandwidth with 1 and 2 threads (a sum over a buffer
// much larger than the caches). The factorization is compared with the first (compute-bound), the
// triangular solves with the second (they stream the factor).
//
//   bench-machine-limits [N=4000] [MB=2048]
// prints one line: dgemm_n=... dgemm_gflops=... read_gbs_1=... read_gbs_2=...
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

extern "C" void dgemm_(const char *, const char *, const int *, const int *, const int *, const double *,
                       const double *, const int *, const double *, const int *, const double *, double *,
                       const int *);

namespace
{
  double seconds_since(const std::chrono::steady_clock::time_point start)
  {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  // Best of three C = A B with n x n matrices [GFLOP/s].
  double dgemm_rate(const int n)
  {
    std::vector<double> A(std::size_t(n) * n), B(A.size()), C(A.size(), 0.);
    for (std::size_t i = 0; i < A.size(); ++i)
      {
        A[i] = double(i % 7) - 3.;
        B[i] = double(i % 5) - 2.;
      }
    const double one = 1., zero = 0.;
    double       best = 0.;
    for (int repetition = 0; repetition < 3; ++repetition)
      {
        const auto start = std::chrono::steady_clock::now();
        dgemm_("N", "N", &n, &n, &n, &one, A.data(), &n, B.data(), &n, &zero, C.data(), &n);
        best = std::max(best, 2. * n * double(n) * n / seconds_since(start) / 1e9);
      }
    return best;
  }

  // Best of three sums over the buffer, split between 'threads' threads [GB/s].
  double read_bandwidth(const std::vector<double> &buffer, const unsigned int threads)
  {
    double best = 0.;
    for (int repetition = 0; repetition < 3; ++repetition)
      {
        std::vector<double>      partial(threads * 8, 0.);
        std::vector<std::thread> workers;
        const auto               start = std::chrono::steady_clock::now();
        const std::size_t        share = buffer.size() / threads;
        for (unsigned int t = 0; t < threads; ++t)
          workers.emplace_back([&, t] {
            double s0 = 0., s1 = 0., s2 = 0., s3 = 0.;
            const double *x = buffer.data() + t * share;
            for (std::size_t i = 0; i + 4 <= share; i += 4)
              {
                s0 += x[i];
                s1 += x[i + 1];
                s2 += x[i + 2];
                s3 += x[i + 3];
              }
            partial[t * 8] = s0 + s1 + s2 + s3;
          });
        for (auto &w : workers)
          w.join();
        const double elapsed = seconds_since(start);
        if (partial[0] != 12345.) // keeps the sums alive
          best = std::max(best, 8. * share * threads / elapsed / 1e9);
      }
    return best;
  }
} // namespace

int main(int argc, char **argv)
{
  const int         n  = argc > 1 ? std::stoi(argv[1]) : 4000;
  const std::size_t mb = argc > 2 ? std::stoul(argv[2]) : 2048;
  const double      gflops = dgemm_rate(n);
  std::vector<double> buffer(mb * 1024 * 1024 / 8, 1.);
  std::printf("machine dgemm_n=%d dgemm_gflops=%.2f read_gbs_1=%.2f read_gbs_2=%.2f\n", n, gflops,
              read_bandwidth(buffer, 1), read_bandwidth(buffer, 2));
  return 0;
}
