// Small helpers shared by the kernel's tests: Box2D-style checks that report and count failures,
// and synthetic bases loaded straight from memory.
#pragma once

#include "synthetic_scene.h"

#include <modalrt/modalrt.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace test
{
  inline int &failures()
  {
    static int count = 0;
    return count;
  }

  inline void report(bool ok, const char *file, int line, const std::string &what)
  {
    if (!ok)
      {
        ++failures();
        std::fprintf(stderr, "%s:%d: FAILED: %s\n", file, line, what.c_str());
      }
  }

  inline int finish(const char *name)
  {
    if (failures() == 0)
      std::printf("%s: all checks passed\n", name);
    else
      std::printf("%s: %d check(s) FAILED\n", name, failures());
    return failures() == 0 ? 0 : 1;
  }

  inline std::string number(double x)
  {
    char text[64];
    std::snprintf(text, sizeof text, "%.17g", x);
    return text;
  }
} // namespace test

#define ENSURE(condition) test::report(bool(condition), __FILE__, __LINE__, #condition)
// |a - b| <= tolerance, printing both values on failure.
#define ENSURE_NEAR(a, b, tolerance)                                                                                   \
  do                                                                                                                   \
    {                                                                                                                  \
      const double ensure_a_ = (a), ensure_b_ = (b);                                                                   \
      test::report(std::fabs(ensure_a_ - ensure_b_) <= (tolerance), __FILE__, __LINE__,                                \
                   std::string(#a " = ") + test::number(ensure_a_) + ", " #b " = " + test::number(ensure_b_) +         \
                     ", tolerance " + test::number(tolerance));                                                        \
    }                                                                                                                  \
  while (0)
// |a - b| <= tolerance |b|.
#define ENSURE_RELATIVE(a, b, tolerance) ENSURE_NEAR(a, b, (tolerance) * std::fabs(double(b)))

namespace test
{
  // A basis loaded from the bytes of a synthetic scene; aborts the test on failure.
  inline modalrt_basis *load(const modalrt::BasisContent &content)
  {
    const std::vector<unsigned char> bytes = modalrt::write_basis(content);
    modalrt_basis                   *basis = nullptr;
    if (modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis) != MODALRT_OK)
      {
        std::fprintf(stderr, "cannot load the synthetic basis: %s\n", modalrt_last_error_message());
        std::exit(1);
      }
    return basis;
  }

  inline modalrt_kernel *create(const modalrt_basis *basis, const modalrt_kernel_def &def)
  {
    modalrt_kernel *kernel = nullptr;
    if (modalrt_kernel_create(basis, &def, &kernel) != MODALRT_OK)
      {
        std::fprintf(stderr, "cannot create the kernel: %s\n", modalrt_last_error_message());
        std::exit(1);
      }
    return kernel;
  }

  inline modalrt_hip_input hip_at(const double *x, double fx = 0.0, double fy = 0.0, double fz = 0.0)
  {
    modalrt_hip_input in{};
    for (int d = 0; d < 3; ++d)
      in.position[d] = x[d];
    in.force[0] = fx;
    in.force[1] = fy;
    in.force[2] = fz;
    return in;
  }

  // Every number of a HIP's output is finite.
  inline bool finite(const modalrt_hip_output &o)
  {
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(o.position[d]) || !std::isfinite(o.velocity[d]) || !std::isfinite(o.force[d]))
        return false;
    return true;
  }

  // The whole text of a file ("" if it cannot be read).
  inline std::string read_text(const std::string &path)
  {
    std::ifstream     file(path);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
  }

  // The number after "key": in a stats.json text, searched from `from` (NaN if absent).
  inline double json_number(const std::string &json, const std::string &key, std::size_t from = 0)
  {
    const std::size_t at = json.find("\"" + key + "\": ", from);
    return at == std::string::npos ? std::nan("") : std::strtod(json.c_str() + at + key.size() + 4, nullptr);
  }

  inline double distance(const double *a, const double *b)
  {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
  }
} // namespace test
