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
//                      [--repetitions N] [--basis FILE.mrt]
// The display surface is the synthetic analytic plate (bench_support.h), one modal space, or a real
// basis file; a 100-tick press of 1 N at a candidate vertex of space 0 is behind the snapshot. With float32
// modes a fourth row studies a 16-bit storage of the modes (int16 with a per-mode scale, a loop of
// this benchmark, not of the kernel): its time and its error against the kernel's float32 result.
#include "basis.h"
#include "bench_support.h"
#include "../command_line.h"

#include <cblas.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
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
    std::string                basis_file; // a real .mrt instead of the plates
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
  const float *display_modes(const modalrt::ModalSpace &space, float *) { return space.display_modes_f32.data(); }
  const double *display_modes(const modalrt::ModalSpace &space, double *) { return space.display_modes_f64.data(); }

  // A snapshot of the plate pressed at a candidate vertex: a nonzero modal state to reconstruct.
  modalrt_snapshot *pressed_snapshot(const modalrt_basis *basis, modalrt_kernel *&kernel)
  {
    modalrt_kernel_def def = modalrt_kernel_default_def();
    modalrt_kernel_create(basis, &def, &kernel);
    const std::uint32_t v = modalrt_basis_candidates(basis, 0)[1];
    modalrt_kernel_contact_begin(kernel, 0, v);
    modalrt_hip_input in{};
    std::memcpy(in.position, modalrt_basis_display_vertices(basis) + 3 * std::size_t(v), sizeof in.position);
    for (int d = 0; d < 3; ++d) // 1 N into the surface
      in.force[d] = -modalrt_basis_display_normals(basis)[3 * std::size_t(v) + d];
    modalrt_hip_output out;
    for (int n = 0; n < 100; ++n)
      modalrt_kernel_tick_admittance(kernel, &in, 1, &out);
    modalrt_snapshot *snapshot = nullptr;
    modalrt_snapshot_create(kernel, &snapshot);
    modalrt_kernel_snapshot_read(kernel, snapshot);
    return snapshot;
  }

  // The 16-bit study: each mode stored as int16 with its own scale s_i = max |Phi_.i| / 32767, and
  // u = sum_i Phi16_.i (s_i q_i): half the bytes of float32 modes. Only in this benchmark (the
  // .mrt format has no such section); its error against the kernel's float32 result is reported.
  struct Int16Modes
  {
    std::vector<std::int16_t> values; // 3 nv x r, the layout of DISPLAY_MODES
    std::vector<float>        scale;  // r
  };

  Int16Modes quantize(const float *phi, std::size_t rows, std::uint32_t r)
  {
    Int16Modes m;
    m.scale.assign(r, 0.0f);
    for (std::size_t k = 0; k < rows * r; ++k)
      m.scale[k % r] = std::max(m.scale[k % r], std::fabs(phi[k]));
    for (float &s : m.scale)
      s = s > 0.0f ? s / 32767.0f : 1.0f;
    m.values.resize(rows * r);
    for (std::size_t k = 0; k < rows * r; ++k)
      m.values[k] = std::int16_t(std::lround(phi[k] / m.scale[k % r]));
    return m;
  }

  void reconstruct_int16(const Int16Modes &m, const float *q, std::size_t rows, std::uint32_t r, float *scaled_q,
                         float *out)
  {
    for (std::uint32_t i = 0; i < r; ++i)
      scaled_q[i] = m.scale[i] * q[i];
    for (std::size_t row = 0; row < rows; ++row)
      {
        const std::int16_t *a   = &m.values[row * r];
        float               sum = 0.0f;
#pragma omp simd reduction(+ : sum)
        for (std::uint32_t i = 0; i < r; ++i)
          sum += float(a[i]) * scaled_q[i];
        out[row] = sum;
      }
  }

  struct Method
  {
    const char           *name;
    std::size_t           bytes;  // read per call (memcpy: copied)
    std::function<void()> call;
    const void           *output; // compared with the kernel's (nullptr: no output)
  };

  // Times the methods interleaved on `basis` and prints one row per method.
  template <typename Scalar>
  void measure(const Options &o, const char *precision, const modalrt_basis *basis)
  {
    modalrt_kernel     *kernel   = nullptr;
    modalrt_snapshot   *snapshot = pressed_snapshot(basis, kernel);
    modalrt_snapshot_info info; // the press may have switched space: reconstruct the snapshot's
    modalrt_snapshot_get_info(snapshot, &info);
    const std::uint32_t nv = basis->vertex_count, r = info.mode_count;
    const std::size_t   rows = 3 * std::size_t(nv), bytes = rows * r * sizeof(Scalar);
    const Scalar       *phi = display_modes(basis->spaces[info.space], static_cast<Scalar *>(nullptr));
    const double       *q64 = modalrt_snapshot_modal_coordinates(snapshot);
    const std::vector<Scalar>  q(q64, q64 + r);
    std::vector<Scalar>        by_kernel(rows), by_blas(rows);
    std::vector<unsigned char> copy(bytes, 0);
    std::vector<Method>        methods = {
      {"kernel", bytes, [&] { kernel_reconstruct(snapshot, nv, by_kernel.data()); }, nullptr},
      {"memcpy", bytes, [&] { std::memcpy(copy.data(), phi, bytes); }, nullptr},
      {sizeof(Scalar) == 4 ? "openblas_sgemv" : "openblas_dgemv", bytes,
       [&] { gemv(phi, q.data(), rows, r, by_blas.data()); }, by_blas.data()}};
    Int16Modes         int16;
    std::vector<float> scaled_q(r), by_int16(rows);
    if constexpr (sizeof(Scalar) == 4)
      {
        int16 = quantize(phi, rows, r);
        methods.push_back({"int16_per_mode_scale", bytes / 2,
                           [&] { reconstruct_int16(int16, q.data(), rows, r, scaled_q.data(), by_int16.data()); },
                           by_int16.data()});
      }

    for (const Method &m : methods) // warm-up: page faults of the outputs, OpenBLAS's threads
      m.call();
    const std::size_t   count = methods.size();
    std::vector<std::vector<double>> seconds(count);
    for (int k = 0; k < o.repetitions; ++k)
      for (std::size_t j = 0; j < count; ++j)
        {
          const std::size_t m     = (j + std::size_t(k)) % count; // rotating order
          const auto        start = Clock::now();
          methods[m].call();
          seconds[m].push_back(std::chrono::duration<double>(Clock::now() - start).count());
        }

    double size = 0.0; // |u|max
    for (const Scalar u : by_kernel)
      size = std::max(size, std::fabs(double(u)));
    for (std::size_t m = 0; m < count; ++m)
      {
        // OpenBLAS sums in another order (a few ulps of |u|max); int16 adds its quantization error.
        double diff = 0.0;
        if (methods[m].output)
          for (std::size_t i = 0; i < rows; ++i)
            diff = std::max(diff, std::fabs(double(static_cast<const Scalar *>(methods[m].output)[i]) - by_kernel[i]));
        std::vector<double> speed(seconds[m].size());
        for (std::size_t k = 0; k < speed.size(); ++k)
          speed[k] = seconds[m][k] / seconds[0][k];
        const auto t = modalrt_bench::spread(seconds[m]), s = modalrt_bench::spread(speed);
        std::printf("%s,%u,%u,%zu,%s,%d,%.4f,%.4f,%.4f,%.2f,%.3f,%.3f,%.3f,%.1e\n", precision, r, nv, methods[m].bytes,
                    methods[m].name, o.repetitions, 1e3 * t.median, 1e3 * t.min, 1e3 * t.max,
                    double(methods[m].bytes) / t.median * 1e-9, s.median, s.min, s.max, diff / size);
      }
    std::fflush(stdout);
    modalrt_snapshot_destroy(snapshot);
    modalrt_kernel_destroy(kernel);
  }

  template <typename Scalar>
  void run_plate(const Options &o, const char *precision, std::uint32_t vertices, std::uint32_t r)
  {
    modalrt::PlateOptions plate;
    plate.nx = plate.ny = std::uint32_t(std::lround(std::sqrt(double(vertices))));
    plate.modes         = r;
    plate.spaces        = 1;
    plate.candidates    = 8;
    plate.float64_modes = sizeof(Scalar) == 8;
    modalrt_basis *basis = modalrt_bench::load_plate(plate, "bench-display");
    measure<Scalar>(o, precision, basis);
    modalrt_basis_destroy(basis);
  }

  using modal_haptics_bench::numbers;
  using modal_haptics_bench::split;

  [[noreturn]] void usage()
  {
    modal_haptics_bench::usage("bench-display [--vertices 10000,100000,300000] [--modes 50,200] [--precision f32,f64] "
                               "[--repetitions N] [--basis FILE.mrt]");
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
            else if (arg == "--basis")
              o.basis_file = argv[++k];
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
  if (!o.basis_file.empty())
    {
      modalrt_basis *basis = nullptr;
      if (modalrt_basis_load(o.basis_file.c_str(), &basis) != MODALRT_OK)
        {
          std::fprintf(stderr, "bench-display: %s\n", modalrt_last_error_message());
          return 1;
        }
      if (basis->float64_modes())
        measure<double>(o, "f64", basis);
      else
        measure<float>(o, "f32", basis);
      modalrt_basis_destroy(basis);
      return 0;
    }
  for (const std::string &precision : o.precisions)
    for (std::uint32_t vertices : o.vertices)
      for (std::uint32_t r : o.modes)
        if (precision == "f32")
          run_plate<float>(o, "f32", vertices, r);
        else
          run_plate<double>(o, "f64", vertices, r);
  return 0;
}
