// bench-kernel-tick: cost of one haptic tick (the display reconstruction: bench-display).
//
// CSV "tick" rows: per-tick latency percentiles (and the ticks above 5 us per thousand) over N ticks
// (default 10^6) for r in
// {20, 50, 200, 1000}, 1 to 4 HIPs held in contact at candidate vertices, with and without the
// static correction, for the admittance and the impedance step; a "hover" row where the HIPs hover
// just above the surface, so that every tick runs the snap search; and a "landing" row timing only
// the ticks where a contact starts and the modal space switches (row build, transfer, coupling);
// "slide" and "fixed" rows: one HIP 1 mm deep moving to and fro over the plate at 0.1 m/s, with a
// sliding proxy contact (mu_s 0.3, mu_d 0.2) or with the fixed (snap) contact it starts with, the two
// kernels ticked alternately in one loop (the machine's load falls on both alike), and a "machine"
// row timed in the same loop (constant work as long as the fixed tick: the tail the machine alone
// adds), the three again on the plate whose every vertex is a candidate ("-every-vertex"); a comment
// line before them gives each one's passivity observer at the end and its lowest value; "sampled",
// "every-vertex" and "far-field" rows: the corrected 2-HIP admittance tick on the plate with 32
// candidates per space, on the same plate whose every display vertex is a candidate with cross rows
// to the vertices it shares a triangle with (all exact), and on that one with a far field of
// rank 64 (.mrt 1.3) coupling the two HIPs, which are not neighbours; the three kernels ticked in
// turn at the same vertices; a comment line before them gives the bases' sizes and the ratios of
// their p50s to the sampled one's; "impedance-unscaled-in-turn" and "impedance-scaled-in-turn": the
// corrected impedance tick with 1 and 2 HIPs without and with the haptic mapping (omega.x, s = 0.01),
// the two kernels ticked in turn, after a comment line with the ratios of their p50 and p99.
//
// Usage: bench-kernel-tick [--ticks N] [--vertices-per-side N] [--modes r1,r2,...] [--basis FILE]
//                          [--slide-only | --every-vertex-only | --mapping-only]
// The basis is a synthetic analytic plate (float32 modes, two spaces, 32 candidates per space), or
// the given .mrt file (its space 0 and, for the landing row, space 1; no sampled/every-vertex/far-field
// rows; the slide along the largest flat face of space 0's region: surface_path).
#include "bench_support.h"

#include <modalrt/modalrt.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace
{
  using Clock = std::chrono::steady_clock;

  struct Options
  {
    long                       ticks              = 1000000;
    std::uint32_t              vertices_per_side  = 64;
    std::vector<std::uint32_t> modes              = {20, 50, 200, 1000};
    std::string                basis_file;
    bool                       slide_only        = false; // only the "slide" and "fixed" rows
    bool                       every_vertex_only = false; // only the "sampled", "every-vertex", "far-field" rows
    bool                       mapping_only      = false; // only the "impedance-*-in-turn" rows
  };

  struct Percentiles
  {
    double p50, p99, p999, max, mean;
    double over_5us_per_mille; // ticks above the 5 us goal, per thousand
  };

  Percentiles percentiles(std::vector<std::uint32_t> &ns)
  {
    Percentiles p{};
    double      sum = 0.0;
    std::size_t over = 0;
    for (std::uint32_t x : ns)
      {
        sum += x;
        over += x > 5000;
      }
    p.over_5us_per_mille = 1000.0 * double(over) / double(ns.size());
    p.mean   = sum / double(ns.size());
    auto at  = [&](double fraction) {
      const std::size_t k = std::min(ns.size() - 1, std::size_t(fraction * double(ns.size())));
      std::nth_element(ns.begin(), ns.begin() + long(k), ns.end());
      return double(ns[k]);
    };
    p.p50  = at(0.5);
    p.p99  = at(0.99);
    p.p999 = at(0.999);
    p.max  = double(*std::max_element(ns.begin(), ns.end()));
    return p;
  }

  std::uint32_t elapsed_ns(Clock::time_point start, Clock::time_point stop)
  {
    return std::uint32_t(std::chrono::duration_cast<std::chrono::nanoseconds>(stop - start).count());
  }

  modalrt_basis *load_basis_file(const std::string &path)
  {
    modalrt_basis *basis = nullptr;
    if (modalrt_basis_load(path.c_str(), &basis) != MODALRT_OK)
      {
        std::fprintf(stderr, "bench-kernel-tick: %s\n", modalrt_last_error_message());
        std::exit(1);
      }
    return basis;
  }

  // The far field's rank on the every-vertex plate: the precompute's default 'Contact/Far field rank'.
  constexpr std::uint32_t far_field_rank = 64;

  // The synthetic plate: 32 candidates per space, or every display vertex a candidate (with a far
  // field of far_rank when > 0).
  modalrt_basis *make_basis(const Options &o, std::uint32_t r, bool every_vertex = false, std::uint32_t far_rank = 0)
  {
    modalrt::PlateOptions plate;
    plate.nx = plate.ny  = o.vertices_per_side;
    plate.modes          = r;
    plate.float64_modes  = false;
    plate.patch_radius   = 2.5 * plate.length / (plate.nx - 1); // about 20 vertices per patch
    plate.every_vertex_candidates = every_vertex;
    plate.far_rank                = far_rank;
    return modalrt_bench::load_plate(plate, "bench-kernel-tick");
  }

  enum class Scenario
  {
    admittance,
    impedance,
    impedance_scaled, // impedance with the haptic mapping (the omega.x profile, s = 0.01)
    hover,
    landing
  };

  const char *name(Scenario s)
  {
    switch (s)
      {
        case Scenario::admittance: return "admittance";
        case Scenario::impedance: return "impedance";
        case Scenario::impedance_scaled: return "impedance_scaled";
        case Scenario::hover: return "hover";
        default: return "landing";
      }
  }

  // Contact starts: one HIP lands every 20 ticks, alternately in the global region and in the VOI of
  // space 1, so that every landing snaps, builds its row, switches space (transfer r x r) and
  // rebuilds the coupling. Only the landing ticks are timed.
  Percentiles run_landings(const modalrt_basis *basis, const Options &o, bool corrected, std::vector<std::uint32_t> &ns)
  {
    modalrt_kernel_def def    = modalrt_kernel_default_def();
    def.hip_capacity          = 1;
    def.use_static_correction = corrected ? 1 : 0;
    modalrt_kernel *k         = nullptr;
    modalrt_kernel_create(basis, &def, &k);
    const double   *x        = modalrt_basis_display_vertices(basis);
    const double   *normals  = modalrt_basis_display_normals(basis);
    const uint32_t *regions  = modalrt_basis_display_regions(basis);
    // Landing sites: candidates of each space inside that space's region.
    std::vector<std::uint32_t> sites[2];
    for (std::uint32_t s = 0; s < 2; ++s)
      {
        modalrt_space_info info;
        modalrt_basis_get_space_info(basis, s, &info);
        const uint32_t *candidates = modalrt_basis_candidates(basis, s);
        for (std::uint32_t c = 0; c < info.candidate_count; ++c)
          if (regions[candidates[c]] == s)
            sites[s].push_back(candidates[c]);
      }
    modalrt_hip_input  in{};
    modalrt_hip_output out;
    const long landings = std::max(1000L, o.ticks / 20);
    ns.resize(std::size_t(landings));
    long recorded = 0;
    for (long n = 0; recorded < landings; ++n)
      {
        const long     cycle = n / 20, phase = n % 20;
        const auto         &site = sites[cycle % 2];
        const std::uint32_t v    = site[std::size_t(cycle / 2) % site.size()];
        // Pressed 0.5 mm in along the vertex normal, then lifted 4 mm out.
        const double depth = phase < 10 ? -0.0005 : 0.004;
        for (int d = 0; d < 3; ++d)
          {
            in.position[d] = x[3 * v + d] + depth * normals[3 * v + d];
            in.force[d]    = (phase < 10 ? -0.5 : 0.5) * normals[3 * v + d];
          }
        const auto start = Clock::now();
        modalrt_kernel_tick_impedance(k, &in, 1, &out);
        const auto stop = Clock::now();
        if (phase == 0 && n >= 200)
          ns[std::size_t(recorded++)] = elapsed_ns(start, stop);
      }
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    if (stats.switch_count < std::uint64_t(landings))
      std::fprintf(stderr, "bench-kernel-tick: only %llu switches for %ld landings\n",
                   (unsigned long long)stats.switch_count, landings);
    modalrt_kernel_destroy(k);
    return percentiles(ns);
  }

  // The machine's floor: a fixed chain of dependent multiply-adds on registers (no memory, no branch
  // that depends on data), so that every run of it does the same work. Whatever spread its times show
  // (interrupts, the hypervisor taking the core, frequency changes) is the machine's, and no code of
  // the same duration can have a smaller tail on this machine.
  volatile double constant_work_result = 1.0; // read back, so that the work is not optimized away

  void constant_work(const long steps)
  {
    double x = constant_work_result;
    for (long k = 0; k < steps; ++k)
      x = x * 0.9999999 + 1e-7;
    constant_work_result = x;
  }

  // The steps of constant_work that take about `target_ns` (the median of 2,000 timed runs of 1,000).
  long steps_lasting(const double target_ns)
  {
    std::vector<std::uint32_t> ns(2000);
    for (auto &t : ns)
      {
        const auto start = Clock::now();
        constant_work(1000);
        t = elapsed_ns(start, Clock::now());
      }
    const double per_step = std::max(0.1, percentiles(ns).p50 / 1000.0);
    return std::max(1L, long(target_ns / per_step));
  }

  struct SlideRows
  {
    Percentiles fixed, slide, machine;
  };

  // The straight line a slide runs along, to and fro: from 'start' (on the surface at rest) along
  // 'direction' over 'length'; 'normal' is the surface's outward normal there.
  struct SlidePath
  {
    double start[3], direction[3], normal[3], length;
  };

  // Three-vectors of the display surface (x, y, z side by side).
  double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  void   difference(const double *a, const double *b, double *a_minus_b)
  {
    for (int c = 0; c < 3; ++c)
      a_minus_b[c] = a[c] - b[c];
  }
  void cross(const double *a, const double *b, double *a_cross_b)
  {
    a_cross_b[0] = a[1] * b[2] - a[2] * b[1];
    a_cross_b[1] = a[2] * b[0] - a[0] * b[2];
    a_cross_b[2] = a[0] * b[1] - a[1] * b[0];
  }
  double distance_squared(const double *a, const double *b)
  {
    double d[3];
    difference(a, b, d);
    return dot(d, d);
  }

  // On the synthetic plate: along x over 70 % of it, y between vertex rows, on its top face.
  SlidePath plate_path(const modalrt_basis_info &info)
  {
    SlidePath path{{info.bounds_min[0] + 0.15 * (info.bounds_max[0] - info.bounds_min[0]),
                    info.bounds_min[1] + 0.4123 * (info.bounds_max[1] - info.bounds_min[1]), info.bounds_max[2]},
                   {1., 0., 0.},
                   {0., 0., 1.},
                   0.7 * (info.bounds_max[0] - info.bounds_min[0])};
    return path;
  }

  // The key shared by the most of 'keys'.
  long fullest(std::vector<long> keys)
  {
    std::sort(keys.begin(), keys.end());
    long best = 0, best_count = 0;
    for (std::size_t i = 0; i < keys.size();)
      {
        std::size_t j = i;
        while (j < keys.size() && keys[j] == keys[i])
          ++j;
        if (long(j - i) > best_count)
          best = keys[i], best_count = long(j - i);
        i = j;
      }
    return best;
  }

  // A flat face of the display surface: its vertices and outward normal.
  struct FlatFace
  {
    std::vector<uint32_t> vertices;
    double                normal[3] = {0., 0., 0.};
  };

  // The largest flat face of space 0's region (its display vertices): their normals are binned
  // (0.1 per component) and the fullest bin's mean is the face's normal n; the vertices within 10
  // degrees of it are binned by their height along n (0.2 mm), and the fullest height bin (with its
  // two neighbours) is the face. No vertices when the region has none.
  FlatFace largest_flat_face(const modalrt_basis *basis, const modalrt_basis_info &info)
  {
    const double   *x = modalrt_basis_display_vertices(basis), *normals = modalrt_basis_display_normals(basis);
    const uint32_t *regions = modalrt_basis_display_regions(basis);
    std::vector<uint32_t> region; // space 0's display vertices
    std::vector<long>     keys;
    for (uint32_t v = 0; v < info.display_vertex_count; ++v)
      if (regions[v] == 0)
        {
          region.push_back(v);
          long key = 0;
          for (int c = 0; c < 3; ++c)
            key = key * 64 + long(std::lround(10. * normals[3 * v + c]) + 32);
          keys.push_back(key);
        }
    FlatFace   face;
    const long normal_bin = keys.empty() ? 0 : fullest(keys);
    for (std::size_t k = 0; k < region.size(); ++k)
      if (keys[k] == normal_bin)
        for (int c = 0; c < 3; ++c)
          face.normal[c] += normals[3 * region[k] + c];
    const double norm = std::sqrt(dot(face.normal, face.normal));
    if (norm == 0.)
      return face;
    for (double &c : face.normal)
      c /= norm;
    std::vector<uint32_t> aligned;
    std::vector<long>     heights;
    for (const uint32_t v : region)
      if (dot(&normals[3 * v], face.normal) > std::cos(10. * M_PI / 180.))
        {
          aligned.push_back(v);
          heights.push_back(std::lround(dot(&x[3 * v], face.normal) / 2e-4));
        }
    const long height = fullest(heights);
    for (std::size_t k = 0; k < aligned.size(); ++k)
      if (std::labs(heights[k] - height) <= 1)
        face.vertices.push_back(aligned[k]);
    return face;
  }

  // The principal axis of the face's vertices in its plane (power iteration on their covariance),
  // and in 'middle' their mean.
  void principal_axis(const FlatFace &face, const double *x, double *axis, double *middle)
  {
    double covariance[9] = {};
    for (int c = 0; c < 3; ++c)
      middle[c] = 0.;
    for (const uint32_t v : face.vertices)
      for (int c = 0; c < 3; ++c)
        middle[c] += x[3 * v + c] / double(face.vertices.size());
    for (const uint32_t v : face.vertices)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          covariance[3 * a + b] += (x[3 * v + a] - middle[a]) * (x[3 * v + b] - middle[b]);
    const bool along_x = std::abs(face.normal[0]) < 0.9;
    axis[0] = along_x ? 1. : 0., axis[1] = along_x ? 0. : 1., axis[2] = 0.;
    for (int iteration = 0; iteration < 100; ++iteration)
      {
        double next[3];
        for (int a = 0; a < 3; ++a)
          next[a] = dot(&covariance[3 * a], axis);
        const double along_normal = dot(next, face.normal);
        for (int a = 0; a < 3; ++a)
          next[a] -= along_normal * face.normal[a];
        const double length = std::sqrt(dot(next, next));
        if (length == 0.)
          break;
        for (int a = 0; a < 3; ++a)
          axis[a] = next[a] / length;
      }
  }

  // The mean edge length of the display triangles.
  double mean_edge(const modalrt_basis *basis, const modalrt_basis_info &info)
  {
    const double   *x         = modalrt_basis_display_vertices(basis);
    const uint32_t *triangles = modalrt_basis_display_triangles(basis);
    double          edges     = 0.;
    for (uint32_t t = 0; t < info.display_triangle_count; ++t)
      for (int e = 0; e < 3; ++e)
        edges += std::sqrt(distance_squared(&x[3 * triangles[3 * t + e]], &x[3 * triangles[3 * t + (e + 1) % 3]]));
    return edges / std::max(1., 3. * info.display_triangle_count);
  }

  // The face's triangles (all three vertices on it).
  std::vector<const uint32_t *> face_triangles(const modalrt_basis *basis, const modalrt_basis_info &info,
                                               const FlatFace &face)
  {
    const uint32_t   *triangles = modalrt_basis_display_triangles(basis);
    std::vector<char> in_face(info.display_vertex_count, 0);
    for (const uint32_t v : face.vertices)
      in_face[v] = 1;
    std::vector<const uint32_t *> on_face;
    for (uint32_t t = 0; t < info.display_triangle_count; ++t)
      if (in_face[triangles[3 * t]] && in_face[triangles[3 * t + 1]] && in_face[triangles[3 * t + 2]])
        on_face.push_back(&triangles[3 * t]);
    return on_face;
  }

  // Whether p lies on one of the triangles, seen along 'normal' (the three edges turn the same way
  // around it).
  bool on_triangles(const std::vector<const uint32_t *> &triangles, const double *x, const double *normal,
                    const double *p)
  {
    for (const uint32_t *t : triangles)
      {
        int positive = 0, negative = 0;
        for (int e = 0; e < 3; ++e)
          {
            double ab[3], ap[3], turn[3];
            difference(&x[3 * t[(e + 1) % 3]], &x[3 * t[e]], ab);
            difference(p, &x[3 * t[e]], ap);
            cross(ab, ap, turn);
            const double side = dot(turn, normal);
            positive += side >= 0.;
            negative += side <= 0.;
          }
        if (positive == 3 || negative == 3)
          return true;
      }
    return false;
  }

  // On a basis file: over the largest flat face of space 0's region (largest_flat_face), along its
  // longest extent (principal_axis, through the vertex nearest the face's middle, shifted by a third
  // of an edge off the vertices), as far as the line stays on the face's triangles (in steps of half
  // a mean edge), 5 % short of either end. Empty (length 0) when no such line is 3 edges long.
  SlidePath surface_path(const modalrt_basis *basis)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    const double  *x    = modalrt_basis_display_vertices(basis);
    const FlatFace face = largest_flat_face(basis, info);
    SlidePath      path{{0., 0., 0.}, {0., 0., 0.}, {face.normal[0], face.normal[1], face.normal[2]}, 0.};
    if (face.vertices.empty())
      return path;
    double axis[3], middle[3];
    principal_axis(face, x, axis, middle);
    const double edge           = mean_edge(basis, info);
    uint32_t     nearest_middle = face.vertices[0];
    for (const uint32_t v : face.vertices)
      if (distance_squared(&x[3 * v], middle) < distance_squared(&x[3 * nearest_middle], middle))
        nearest_middle = v;
    double across[3], origin[3];
    cross(face.normal, axis, across);
    for (int c = 0; c < 3; ++c)
      origin[c] = x[3 * nearest_middle + c] + edge / 3. * across[c];
    const auto triangles = face_triangles(basis, info, face);
    const auto on_face   = [&](const double s) {
      double p[3];
      for (int c = 0; c < 3; ++c)
        p[c] = origin[c] + s * axis[c];
      return on_triangles(triangles, x, face.normal, p);
    };
    double low = 0., high = 0.;
    while (on_face(low - edge / 2.))
      low -= edge / 2.;
    while (on_face(high + edge / 2.))
      high += edge / 2.;
    if (high - low < 3. * edge)
      return path;
    for (int c = 0; c < 3; ++c)
      {
        path.start[c]     = origin[c] + (low + 0.05 * (high - low)) * axis[c];
        path.direction[c] = axis[c];
      }
    path.length = 0.9 * (high - low);
    return path;
  }

  // One HIP 1 mm deep, moving to and fro along a straight line at 0.1 m/s (plate_path,
  // surface_path), through two kernels ticked alternately in one loop, so that the machine's load
  // falls on both alike: a sliding proxy contact (mu_s 0.3, mu_d 0.2) and the fixed (snap) contact it
  // starts with (auto_release off: it stays at its vertex). A third timed piece in the same loop, the
  // machine's floor (constant_work lasting the fixed tick's median over the warm-up), says what tail
  // the machine alone puts on code of that duration.
  SlideRows run_slide(const modalrt_basis *basis, const Options &o)
  {
    modalrt_kernel *kernels[2] = {nullptr, nullptr};
    for (int proxy = 0; proxy < 2; ++proxy)
      {
        modalrt_kernel_def def = modalrt_kernel_default_def();
        def.hip_capacity       = 1;
        def.contact_mode       = proxy ? MODALRT_CONTACT_PROXY : MODALRT_CONTACT_SNAP;
        def.switch_rule        = MODALRT_SWITCH_NEVER;
        def.auto_release       = 0;
        modalrt_kernel_create(basis, &def, &kernels[proxy]);
      }
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    const SlidePath path = o.basis_file.empty() ? plate_path(info) : surface_path(basis);
    if (path.length == 0.)
      {
        std::fprintf(stderr, "bench-kernel-tick: %s: space 0's region has no flat face long enough for a slide\n",
                     o.basis_file.c_str());
        std::exit(1);
      }
    const double       span = path.length, speed = 0.1, depth = 0.001;
    modalrt_hip_input  in{};
    modalrt_hip_output out[2];
    const long warmup = 10000;
    std::vector<std::uint32_t> ns[3], warmup_fixed;
    std::vector<std::uint32_t> entering, within; // the sliding ticks that enter a triangle, the others
    std::uint32_t              triangle = MODALRT_NONE;
    double                     lowest[2] = {0.0, 0.0}; // [J] the passivity observer's lowest value
    for (auto &v : ns)
      v.resize(std::size_t(o.ticks));
    long floor_steps = 0;
    for (long n = -warmup; n < o.ticks; ++n)
      {
        if (n == 0)
          floor_steps = steps_lasting(percentiles(warmup_fixed).p50);
        const double travel = std::fmod(speed * 1e-3 * double(n + warmup), 2.0 * span);
        for (int c = 0; c < 3; ++c)
          {
            in.position[c] = path.start[c] + (travel < span ? travel : 2.0 * span - travel) * path.direction[c] -
                             depth * path.normal[c];
            in.velocity[c] = (travel < span ? speed : -speed) * path.direction[c];
          }
        for (int piece = 0; piece < 3; ++piece) // rotate which one goes first
          {
            const int which = int((piece + n % 3 + 3) % 3);
            if (which == 2)
              {
                if (n < 0)
                  continue;
                const auto start = Clock::now();
                constant_work(floor_steps);
                ns[2][std::size_t(n)] = elapsed_ns(start, Clock::now());
                continue;
              }
            const auto start = Clock::now();
            modalrt_kernel_tick_impedance(kernels[which], &in, 1, &out[which]);
            const auto stop = Clock::now();
            if (n >= 0)
              ns[which][std::size_t(n)] = elapsed_ns(start, stop);
            else if (which == 0)
              warmup_fixed.push_back(elapsed_ns(start, stop));
            if (which == 1 && n >= 0)
              (out[1].proxy_triangle != triangle ? entering : within).push_back(elapsed_ns(start, stop));
            if (which == 1)
              triangle = out[1].proxy_triangle;
            modalrt_kernel_stats stats;
            modalrt_kernel_get_stats(kernels[which], &stats);
            lowest[which] = std::min(lowest[which], stats.passivity_energy);
          }
      }
    if (!out[0].in_contact || !out[1].in_contact)
      std::fprintf(stderr, "bench-kernel-tick: a sliding or fixed HIP lost its contact\n");
    // The passivity observer of each (Hannaford & Ryu: the work the moving HIP did on the kernel).
    modalrt_kernel_stats stats[2];
    for (int k = 0; k < 2; ++k)
      modalrt_kernel_get_stats(kernels[k], &stats[k]);
    modalrt_space_info space;
    modalrt_basis_get_space_info(basis, 0, &space);
    std::printf("# slide r=%u, %u candidates in space 0, to and fro over %.1f mm from (%.4f, %.4f, %.4f) m along (%.3f, "
                "%.3f, %.3f), 1 mm under the face whose normal is (%.3f, %.3f, %.3f): passivity observer over %ld ticks: fixed %+.6g J (lowest %+.3g J), sliding %+.6g J "
                "(lowest %+.3g J); machine floor: %ld dependent multiply-adds; sliding ticks entering a triangle: %zu",
                space.mode_count, space.candidate_count, 1e3 * path.length, path.start[0], path.start[1], path.start[2],
                path.direction[0], path.direction[1], path.direction[2], path.normal[0], path.normal[1], path.normal[2],
                o.ticks + warmup, stats[0].passivity_energy, lowest[0],
                stats[1].passivity_energy, lowest[1], floor_steps, entering.size());
    for (auto *part : {&entering, &within})
      if (!part->empty())
        {
          const Percentiles p = percentiles(*part);
          std::printf("%sp50 %.0f ns, over 5 us %.1f per mille", part == &entering ? ", " : "; the others ", p.p50,
                      p.over_5us_per_mille);
        }
    std::printf("\n");
    for (modalrt_kernel *k : kernels)
      modalrt_kernel_destroy(k);
    return {percentiles(ns[0]), percentiles(ns[1]), percentiles(ns[2])};
  }

  // A kernel whose HIPs stay where their contacts begin (no switch of space, no release).
  modalrt_kernel *create_held_kernel(const modalrt_basis *basis, std::uint32_t hips, bool corrected,
                                     bool scaled = false)
  {
    modalrt_kernel_def def    = modalrt_kernel_default_def();
    if (scaled)
      {
        modalrt_device_profile_find("omega.x", &def.device);
        def.haptic_scale = 0.01;
      }
    def.hip_capacity          = hips;
    def.use_static_correction = corrected ? 1 : 0;
    def.switch_rule           = MODALRT_SWITCH_NEVER;
    def.auto_release          = 0;
    modalrt_kernel *k         = nullptr;
    if (modalrt_kernel_create(basis, &def, &k) != MODALRT_OK)
      {
        std::fprintf(stderr, "bench-kernel-tick: %s\n", modalrt_last_error_message());
        std::exit(1);
      }
    return k;
  }

  // HIP h presses candidate 3 + 7h of the global space, wrapped into the space's candidates (a small
  // lattice has 16: the unwrapped index read past the array for the third and fourth HIP).
  void contact_sites(const modalrt_basis *basis, std::uint32_t hips, std::uint32_t site[4])
  {
    const uint32_t *candidates = modalrt_basis_candidates(basis, 0);
    modalrt_space_info space;
    modalrt_basis_get_space_info(basis, 0, &space);
    for (std::uint32_t h = 0; h < hips; ++h)
      site[h] = candidates[(3 + 7 * h) % space.candidate_count];
  }

  // Each HIP 1 mm in along its site's normal, its contact begun there; or hovering 2 mm out.
  void place_hips(modalrt_kernel *k, const modalrt_basis *basis, const std::uint32_t *site, std::uint32_t hips,
                  bool hover, modalrt_hip_input in[4])
  {
    const double *x       = modalrt_basis_display_vertices(basis);
    const double *normals = modalrt_basis_display_normals(basis);
    std::memset(in, 0, 4 * sizeof(modalrt_hip_input));
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        const std::uint32_t v = site[h];
        for (int d = 0; d < 3; ++d)
          in[h].position[d] = x[3 * v + d] + (hover ? 0.002 : -0.001) * normals[3 * v + d];
        if (!hover)
          modalrt_kernel_contact_begin(k, h, v);
      }
  }

  // The slowly varying press of tick `tick`: force and velocity along each site's normal.
  void press(long tick, const modalrt_basis *basis, const std::uint32_t *site, std::uint32_t hips, modalrt_hip_input *in)
  {
    const double *normals = modalrt_basis_display_normals(basis);
    const double  t       = 1e-3 * double(tick);
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        const double *n = normals + 3 * site[h];
        for (int d = 0; d < 3; ++d)
          {
            in[h].force[d]    = (-0.5 - 0.3 * std::sin(3.0 * t + h)) * n[d];
            in[h].velocity[d] = 1e-4 * std::cos(5.0 * t) * n[d];
          }
      }
  }

  // HIPs at candidate vertices of the global space, pressing with slowly varying inputs.
  Percentiles run(const modalrt_basis *basis, const Options &o, Scenario scenario, std::uint32_t hips, bool corrected,
                  std::vector<std::uint32_t> &ns)
  {
    modalrt_kernel *k = create_held_kernel(basis, hips, corrected, scenario == Scenario::impedance_scaled);
    std::uint32_t   site[4];
    contact_sites(basis, hips, site);
    modalrt_hip_input  in[4];
    modalrt_hip_output out[4];
    place_hips(k, basis, site, hips, scenario == Scenario::hover, in);
    const long warmup = 10000;
    ns.resize(std::size_t(o.ticks));
    for (long n = -warmup; n < o.ticks; ++n)
      {
        press(n, basis, site, hips, in);
        const auto start = Clock::now();
        if (scenario == Scenario::admittance)
          modalrt_kernel_tick_admittance(k, in, hips, out);
        else
          modalrt_kernel_tick_impedance(k, in, hips, out);
        const auto stop = Clock::now();
        if (n >= 0)
          ns[std::size_t(n)] = elapsed_ns(start, stop);
      }
    modalrt_kernel_destroy(k);
    return percentiles(ns);
  }

  // The corrected 2-HIP admittance tick on bases of one plate, the kernels ticked in turn in one loop
  // (the machine's load falls on all alike; which one goes first rotates): the sampled one (32
  // candidates per space), the one whose every display vertex is a candidate with cross rows to its
  // triangles' vertices, and that one with a far field. All HIPs press the same vertices (the sampled
  // basis's sites, candidates of all). Returns one Percentiles per basis, in order.
  constexpr int compared_bases                = 3;
  const char   *basis_names[compared_bases] = {"sampled", "every-vertex", "far-field"};

  // Kernels ticked in turn in one loop (the machine's load falls on all alike; which one goes first
  // rotates), each kernel's HIPs placed at `site` of its basis and pressing as press() does; the
  // kernels are destroyed. One Percentiles per kernel, in order; `out` holds each one's last outputs.
  using Outputs = std::vector<std::array<modalrt_hip_output, 4>>;
  std::vector<Percentiles> tick_in_turn(const std::vector<modalrt_kernel *> &kernels,
                                        const std::vector<const modalrt_basis *> &bases, const std::uint32_t site[4],
                                        std::uint32_t hips, bool impedance, const Options &o, Outputs &out)
  {
    const int count = int(kernels.size());
    std::vector<std::array<modalrt_hip_input, 4>> in(kernels.size());
    out.assign(kernels.size(), {});
    for (int k = 0; k < count; ++k)
      place_hips(kernels[k], bases[k], site, hips, false, in[k].data());
    const long                              warmup = 10000;
    std::vector<std::vector<std::uint32_t>> ns(kernels.size(), std::vector<std::uint32_t>(std::size_t(o.ticks)));
    for (long n = -warmup; n < o.ticks; ++n)
      for (int turn = 0; turn < count; ++turn)
        {
          const int which = int((turn + (n % count + count)) % count);
          press(n, bases[which], site, hips, in[which].data());
          const auto start = Clock::now();
          if (impedance)
            modalrt_kernel_tick_impedance(kernels[which], in[which].data(), hips, out[which].data());
          else
            modalrt_kernel_tick_admittance(kernels[which], in[which].data(), hips, out[which].data());
          const auto stop = Clock::now();
          if (n >= 0)
            ns[which][std::size_t(n)] = elapsed_ns(start, stop);
        }
    for (modalrt_kernel *k : kernels)
      modalrt_kernel_destroy(k);
    std::vector<Percentiles> result;
    for (auto &v : ns)
      result.push_back(percentiles(v));
    return result;
  }

  std::vector<Percentiles> run_bases(const modalrt_basis *const (&bases)[compared_bases], const Options &o)
  {
    const std::uint32_t hips = 2;
    std::uint32_t       site[4];
    contact_sites(bases[0], hips, site);
    std::vector<modalrt_kernel *>       kernels;
    std::vector<const modalrt_basis *> in_turn(bases, bases + compared_bases);
    for (const modalrt_basis *basis : in_turn)
      kernels.push_back(create_held_kernel(basis, hips, true));
    Outputs out;
    auto    result = tick_in_turn(kernels, in_turn, site, hips, false, o, out);
    for (int b = 0; b < compared_bases; ++b)
      for (std::uint32_t h = 0; h < hips; ++h)
        if (!out[b][h].in_contact || !(out[b][h].flags & MODALRT_HIP_CORRECTED))
          std::fprintf(stderr, "bench-kernel-tick: HIP %u on the %s basis is not a corrected contact\n", h,
                       basis_names[b]);
    return result;
  }

  // Whether the far field couples the two HIPs' sites of run_bases (they share no triangle).
  bool far_coupled(const modalrt_basis *basis)
  {
    std::uint32_t site[4];
    double        C[9];
    contact_sites(basis, 2, site);
    return modalrt_basis_pair_coupling(basis, 0, site[0], site[1], C) == MODALRT_COUPLING_FAR;
  }

  Options parse(int argc, char **argv)
  {
    Options o;
    for (int k = 1; k < argc; ++k)
      {
        const std::string arg = argv[k];
        if (arg == "--ticks" && k + 1 < argc)
          o.ticks = std::atol(argv[++k]);
        else if (arg == "--vertices-per-side" && k + 1 < argc)
          o.vertices_per_side = std::uint32_t(std::atol(argv[++k]));
        else if (arg == "--slide-only")
          o.slide_only = true;
        else if (arg == "--every-vertex-only")
          o.every_vertex_only = true;
        else if (arg == "--mapping-only")
          o.mapping_only = true;
        else if (arg == "--basis" && k + 1 < argc)
          o.basis_file = argv[++k];
        else if (arg == "--modes" && k + 1 < argc)
          {
            o.modes.clear();
            for (char *p = argv[++k]; *p;)
              {
                o.modes.push_back(std::uint32_t(std::strtoul(p, &p, 10)));
                if (*p == ',')
                  ++p;
              }
          }
        else
          {
            std::fprintf(stderr, "usage: bench-kernel-tick [--ticks N] [--vertices-per-side N] [--modes r1,r2,...] "
                                 "[--basis FILE] [--slide-only | --every-vertex-only | --mapping-only]\n");
            std::exit(2);
          }
      }
    if (int(o.slide_only) + int(o.every_vertex_only) + int(o.mapping_only) > 1)
      {
        std::fprintf(stderr, "bench-kernel-tick: --slide-only, --every-vertex-only and --mapping-only exclude each other\n");
        std::exit(2);
      }
    return o;
  }

  void print_row(const char *scenario, std::uint32_t r, std::uint32_t hips, bool corrected, const Percentiles &p)
  {
    std::printf("tick,%s,%u,%u,%d,%.0f,%.0f,%.0f,%.0f,%.1f,%.2f\n", scenario, r, hips, corrected ? 1 : 0, p.p50, p.p99,
                p.p999, p.max, p.mean, p.over_5us_per_mille);
    std::fflush(stdout);
  }

  // The cost of the haptic mapping: the corrected impedance tick with 1 and 2 HIPs, a kernel without
  // a scale and one with the omega.x profile at s = 0.01 ticked in turn on one basis; a comment line
  // with the ratios of their p50 and p99, then the rows "impedance-unscaled-in-turn" and
  // "impedance-scaled-in-turn".
  void print_mapping(const modalrt_basis *basis, const Options &o, std::uint32_t r)
  {
    for (std::uint32_t hips = 1; hips <= 2; ++hips)
      {
        std::uint32_t site[4];
        contact_sites(basis, hips, site);
        Outputs    out;
        const auto p = tick_in_turn({create_held_kernel(basis, hips, true), create_held_kernel(basis, hips, true, true)},
                                    {basis, basis}, site, hips, true, o, out);
        std::printf("# mapping r=%u, %u HIP(s), corrected impedance ticked in turn without and with the haptic mapping "
                    "(omega.x, s = 0.01): scaled/unscaled p50 %.3f, p99 %.3f\n",
                    r, hips, p[1].p50 / p[0].p50, p[1].p99 / p[0].p99);
        print_row("impedance-unscaled-in-turn", r, hips, true, p[0]);
        print_row("impedance-scaled-in-turn", r, hips, true, p[1]);
      }
  }

  // The "sampled", "every-vertex" and "far-field" rows of one r, after a comment line with the bases'
  // sizes and the ratios of their p50s to the sampled one's.
  void print_bases(const modalrt_basis *sampled, const Options &o, std::uint32_t r)
  {
    modalrt_basis *every_vertex = make_basis(o, r, true), *far = make_basis(o, r, true, far_field_rank);
    const modalrt_basis *const bases[compared_bases] = {sampled, every_vertex, far};
    const auto                 p = run_bases(bases, o);
    modalrt_basis_info         info[compared_bases];
    modalrt_space_info         space[compared_bases];
    for (int b = 0; b < compared_bases; ++b)
      {
        modalrt_basis_get_info(bases[b], &info[b]);
        modalrt_basis_get_space_info(bases[b], 0, &space[b]);
      }
    std::printf("# basis r=%u, corrected 2-HIP admittance, ticked in turn: sampled %u candidates per space (%.1f MB), "
                "every vertex %u (%.1f MB), with a far field of rank %u (%.1f MB; the two HIPs coupled by it: %s); "
                "every-vertex/sampled p50 %.3f, far-field/sampled p50 %.3f\n",
                r, space[0].candidate_count, 1e-6 * double(info[0].file_bytes), space[1].candidate_count,
                1e-6 * double(info[1].file_bytes), space[2].far_rank, 1e-6 * double(info[2].file_bytes),
                far_coupled(far) ? "yes" : "NO", p[1].p50 / p[0].p50, p[2].p50 / p[0].p50);
    for (int b = 0; b < compared_bases; ++b)
      print_row(basis_names[b], r, 2, true, p[b]);
    modalrt_basis_destroy(every_vertex);
    modalrt_basis_destroy(far);
  }
  // The "fixed", "slide" and "machine" rows on the plate with 32 candidates per space (most rows a
  // sliding proxy meets are patch rows, built ahead of it), then, on the synthetic plate, the same
  // three on the plate whose every display vertex is a candidate (the precompute's default: every row
  // is read in place) as "fixed-every-vertex", "slide-every-vertex" and "machine-every-vertex".
  void print_slide(const modalrt_basis *basis, const Options &o, std::uint32_t r)
  {
    const auto sampled = run_slide(basis, o);
    print_row("fixed", r, 1, true, sampled.fixed);
    print_row("slide", r, 1, true, sampled.slide);
    print_row("machine", r, 1, false, sampled.machine);
    if (!o.basis_file.empty())
      return;
    modalrt_basis *every_vertex = make_basis(o, r, true);
    const auto     rows         = run_slide(every_vertex, o);
    print_row("fixed-every-vertex", r, 1, true, rows.fixed);
    print_row("slide-every-vertex", r, 1, true, rows.slide);
    print_row("machine-every-vertex", r, 1, false, rows.machine);
    modalrt_basis_destroy(every_vertex);
  }
} // namespace

int main(int argc, char **argv)
{
  Options o = parse(argc, argv);
  if (o.basis_file.empty())
    std::printf("# bench-kernel-tick: %ld ticks per row, display surface %u x %u vertices, float32 modes\n", o.ticks,
                o.vertices_per_side, o.vertices_per_side);
  else
    {
      modalrt_basis *probe = load_basis_file(o.basis_file);
      modalrt_space_info info;
      modalrt_basis_get_space_info(probe, 0, &info);
      o.modes = {info.mode_count};
      modalrt_basis_destroy(probe);
      std::printf("# bench-kernel-tick: %ld ticks per row, basis %s (no sampled/every-vertex/far-field rows: synthetic plate only)\n",
                  o.ticks, o.basis_file.c_str());
    }
  std::printf("kind,scenario,r,hips,corrected,p50_ns,p99_ns,p99.9_ns,max_ns,mean_ns,over_5us_per_mille\n");
  std::vector<std::uint32_t> ns;
  const bool all = !o.slide_only && !o.every_vertex_only && !o.mapping_only;
  for (std::uint32_t r : o.modes)
    {
      modalrt_basis *basis = o.basis_file.empty() ? make_basis(o, r) : load_basis_file(o.basis_file);
      const std::vector<Scenario> scenarios =
        all ? std::vector<Scenario>{Scenario::admittance, Scenario::impedance, Scenario::impedance_scaled, Scenario::hover}
            : std::vector<Scenario>{};
      for (Scenario scenario : scenarios)
        for (std::uint32_t hips = 1; hips <= 4; ++hips)
          for (bool corrected : {false, true})
            {
              if (scenario == Scenario::hover && !corrected)
                continue; // no contact: the correction plays no part
              print_row(name(scenario), r, hips, corrected, run(basis, o, scenario, hips, corrected, ns));
            }
      if (all || o.slide_only)
        print_slide(basis, o, r);
      if (all)
        print_row(name(Scenario::landing), r, 1, true, run_landings(basis, o, true, ns));
      if (all || o.mapping_only)
        print_mapping(basis, o, r);
      if ((all || o.every_vertex_only) && o.basis_file.empty())
        print_bases(basis, o, r);
      modalrt_basis_destroy(basis);
    }
  return 0;
}
