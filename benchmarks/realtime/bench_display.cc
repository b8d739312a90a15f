// bench-display: the kernel's display reconstruction u = Phi q of the whole display surface
// (modalrt_display_reconstruct, without the static correction so that all three do the same work)
// against the machine's bandwidth, a memcpy of the same DISPLAY_MODES bytes, and against OpenBLAS
// gemv on the same array (sgemv for float32 modes, dgemv for float64). The three are timed
// interleaved, one call each per repetition in a rotating order, so that a load change on the
// shared machine hits all three alike; each row gives the median, min and max time and the
// per-repetition ratio method time / kernel time (> 1: the kernel is faster).
//
// OpenBLAS runs on one thread, like the display thread of modal-rt. It is linked into this
// program only: the kernel itself has no BLAS.
//
// Usage: bench-display [--vertices 10000,100000,300000] [--modes 50,200] [--precision f32,f64]
//                      [--repetitions N]
// The display surface is the synthetic analytic plate (bench_support.h), one modal space, with a
// 100-tick press at a candidate vertex behind the snapshot.
#include "basis.h"
#include "bench_support.h"

#include <cblas.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
  using Clock = std::chrono::steady_clock;

  struct Options
  {
    std::vector<std::uint32_t> vertices   = {10000, 100000, 300000};
    std::vector<std::uint32_t> modes      = {50, 200};
    std::vector<std::string>   precisions = {"f32", "f64"};
    int                        repetitions = 15;
  };

  // The one call of each method, on float or double modes.
  void kernel_reconstruct(const modalrt_snapshot *s, std::uint32_t nv, float *out)
  {
    modalrt_display_reconstruct(s, 0, nv, MODALRT_DISPLAY_NO_CORRECTION, out);
  }
  void kernel_reconstruct(const modalrt_snapshot *s, std::uint32_t nv, double *out)
  {
    modalrt_display_reconstruct_f64(s, 0, nv, MODALRT_DISPLAY_NO_CORRECTION, out);
  }
  // Phi is 3 nv x r, row-major (a vertex's 3 x r block is contiguous).
  void gemv(const float *phi, const float *q, std::uint32_t rows, std::uint32_t r, float *out)
  {
    cblas_sgemv(CblasRowMajor, CblasNoTrans, int(rows), int(r), 1.0f, phi, int(r), q, 1, 0.0f, out, 1);
  }
  void gemv(const double *phi, const double *q, std::uint32_t rows, std::uint32_t r, double *out)
  {
    cblas_dgemv(CblasRowMajor, CblasNoTrans, int(rows), int(r), 1.0, phi, int(r), q, 1, 0.0, out, 1);
  }
  const float  *display_modes(const modalrt_basis *b, float *) { return b->spaces[0].display_modes_f32.data(); }
  const double *display_modes(const modalrt_basis *b, double *) { return b->spaces[0].display_modes_f64.data(); }

  // A snapshot of the plate pressed at a candidate vertex: a nonzero modal state to reconstruct.
  modalrt_snapshot *pressed_snapshot(const modalrt_basis *basis, modalrt_kernel *&kernel)
  {
    modalrt_kernel_def def = modalrt_kernel_default_def();
    modalrt_kernel_create(basis, &def, &kernel);
    const std::uint32_t v = modalrt_basis_candidates(basis, 0)[1];
    modalrt_kernel_contact_begin(kernel, 0, v);
    modalrt_hip_input in{};
    std::memcpy(in.position, modalrt_basis_display_vertices(basis) + 3 * std::size_t(v), sizeof in.position);
    in.force[2] = -1.0;
    modalrt_hip_output out;
    for (int n = 0; n < 100; ++n)
      modalrt_kernel_tick_admittance(kernel, &in, 1, &out);
    modalrt_snapshot *snapshot = nullptr;
    modalrt_snapshot_create(kernel, &snapshot);
    modalrt_kernel_snapshot_read(kernel, snapshot);
    return snapshot;
  }

  template <typename Scalar>
  void run(const Options &o, const char *precision, std::uint32_t vertices, std::uint32_t r)
  {
    modalrt::PlateOptions plate;
    plate.nx = plate.ny = std::uint32_t(std::lround(std::sqrt(double(vertices))));
    plate.modes         = r;
    plate.spaces        = 1;
    plate.candidates    = 8;
    plate.float64_modes = sizeof(Scalar) == 8;
    modalrt_basis    *basis    = modalrt_bench::load_plate(plate, "bench-display");
    modalrt_kernel   *kernel   = nullptr;
    modalrt_snapshot *snapshot = pressed_snapshot(basis, kernel);

    const std::uint32_t nv    = plate.nx * plate.ny;
    const std::size_t   bytes = std::size_t(3) * nv * r * sizeof(Scalar);
    const Scalar       *phi   = display_modes(basis, static_cast<Scalar *>(nullptr));
    const double       *q64   = modalrt_snapshot_modal_coordinates(snapshot);
    const std::vector<Scalar> q(q64, q64 + r);
    std::vector<Scalar>        by_kernel(3 * std::size_t(nv)), by_blas(3 * std::size_t(nv));
    std::vector<unsigned char> copy(bytes, 0);

    enum Method { kernel_method, memcpy_method, blas_method, method_count };
    const char *names[method_count] = {"kernel", "memcpy", sizeof(Scalar) == 4 ? "openblas_sgemv" : "openblas_dgemv"};
    auto call = [&](int m) {
      if (m == kernel_method)
        kernel_reconstruct(snapshot, nv, by_kernel.data());
      else if (m == memcpy_method)
        std::memcpy(copy.data(), phi, bytes);
      else
        gemv(phi, q.data(), 3 * nv, r, by_blas.data());
    };
    for (int m = 0; m < method_count; ++m) // warm-up: page faults of the outputs, OpenBLAS's threads
      call(m);
    std::vector<double> seconds[method_count];
    for (int k = 0; k < o.repetitions; ++k)
      for (int j = 0; j < method_count; ++j)
        {
          const int  m     = (j + k) % method_count;
          const auto start = Clock::now();
          call(m);
          seconds[m].push_back(std::chrono::duration<double>(Clock::now() - start).count());
        }

    // The kernel and OpenBLAS must agree (float32 sums in a different order: a few ulps of |u|max).
    double diff = 0.0, size = 0.0;
    for (std::size_t i = 0; i < by_kernel.size(); ++i)
      {
        diff = std::max(diff, std::fabs(double(by_kernel[i]) - double(by_blas[i])));
        size = std::max(size, std::fabs(double(by_blas[i])));
      }
    for (int m = 0; m < method_count; ++m)
      {
        std::vector<double> speed(seconds[m].size());
        for (std::size_t k = 0; k < speed.size(); ++k)
          speed[k] = seconds[m][k] / seconds[kernel_method][k];
        const auto t = modalrt_bench::spread(seconds[m]), s = modalrt_bench::spread(speed);
        std::printf("%s,%u,%u,%zu,%s,%d,%.4f,%.4f,%.4f,%.2f,%.3f,%.3f,%.3f,%.1e\n", precision, r, nv, bytes, names[m],
                    o.repetitions, 1e3 * t.median, 1e3 * t.min, 1e3 * t.max, double(bytes) / t.median * 1e-9, s.median,
                    s.min, s.max, m == blas_method ? diff / size : 0.0);
      }
    std::fflush(stdout);
    modalrt_snapshot_destroy(snapshot);
    modalrt_kernel_destroy(kernel);
    modalrt_basis_destroy(basis);
  }

  std::vector<std::string> split(const char *list)
  {
    std::vector<std::string> items;
    std::string              item;
    for (const char *p = list;; ++p)
      if (*p == ',' || *p == '\0')
        {
          items.push_back(item);
          item.clear();
          if (*p == '\0')
            return items;
        }
      else
        item += *p;
  }

  std::vector<std::uint32_t> numbers(const char *list)
  {
    std::vector<std::uint32_t> values;
    for (const std::string &item : split(list))
      values.push_back(std::uint32_t(std::stoul(item)));
    return values;
  }

  [[noreturn]] void usage()
  {
    std::fprintf(stderr, "usage: bench-display [--vertices 10000,100000,300000] [--modes 50,200] "
                         "[--precision f32,f64] [--repetitions N]\n");
    std::exit(2);
  }

  Options parse(int argc, char **argv)
  {
    Options o;
    try
      {
        for (int k = 1; k < argc; ++k)
          {
            const std::string arg = argv[k];
            if (k + 1 >= argc)
              usage();
            if (arg == "--vertices")
              o.vertices = numbers(argv[++k]);
            else if (arg == "--modes")
              o.modes = numbers(argv[++k]);
            else if (arg == "--precision")
              o.precisions = split(argv[++k]);
            else if (arg == "--repetitions")
              o.repetitions = std::stoi(argv[++k]);
            else
              usage();
          }
      }
    catch (const std::logic_error &) // stoul/stoi on a non-number
      {
        usage();
      }
    for (const std::string &p : o.precisions)
      if (p != "f32" && p != "f64")
        usage();
    if (o.repetitions < 1)
      usage();
    return o;
  }
} // namespace

int main(int argc, char **argv)
{
  const Options o = parse(argc, argv);
  openblas_set_num_threads(1);
  std::printf("# bench-display: u = Phi q over the whole display surface, %d interleaved repetitions, "
              "OpenBLAS %s on 1 thread\n",
              o.repetitions, openblas_get_config());
  std::printf("precision,r,vertices,mode_bytes,method,repetitions,median_ms,min_ms,max_ms,GBps_at_median,"
              "method_time_over_kernel_time_median,method_time_over_kernel_time_min,method_time_over_kernel_time_max,"
              "max_diff_to_kernel_rel\n");
  for (const std::string &precision : o.precisions)
    for (std::uint32_t vertices : o.vertices)
      for (std::uint32_t r : o.modes)
        if (precision == "f32")
          run<float>(o, "f32", vertices, r);
        else
          run<double>(o, "f64", vertices, r);
  return 0;
}
