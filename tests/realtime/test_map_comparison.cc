// mrt::compare_maps (mrt/map_comparison.h) on surfaces given as arrays:
//   - a map against itself: the identity rule, no difference anywhere;
//   - B = 1.3 A: +30 % at every vertex (1e-12), ratio 1.3;
//   - the noise floor: vertices within it count as no difference; the largest differences in order;
//   - vertices without a value (0) in A or at B's match are left out and counted; the blend
//     renormalizes the weights over B's vertices with a value;
//   - another triangulation of the same plane (another vertex count: the closest-point rule): a
//     stiffness linear in position is reproduced to 1e-12; a quadratic one k0 (1 + c x^2) within
//     its bound c k0 h^2 / 4 (h: B's triangles' extent in x), which it reaches;
//   - the same surface shifted along its normal by d: the match distance is d, the linear field exact;
//   - the grid's closest point equals a search over every triangle on a curved surface, for points
//     on, near and far from it; 1e5 vertices are matched in well under the test's time.
#include "test_support.h"

#include <mrt/map_comparison.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace
{
  // A triangulated rectangle [x0, x0 + nx h] x [y0, y0 + ny h] at height z(x, y), and a map on it.
  struct Surface
  {
    std::vector<double>        vertices;
    std::vector<std::uint32_t> triangles;
    std::vector<double>        stiffness;

    mrt::SurfaceMap map() const
    {
      return {vertices.data(), vertices.size() / 3, triangles.data(), triangles.size() / 3, stiffness.data()};
    }
    const double *x(std::size_t v) const { return &vertices[3 * v]; }
  };

  template <typename Height>
  Surface grid_surface(double x0, double y0, double h, std::uint32_t nx, std::uint32_t ny, Height z)
  {
    Surface s;
    for (std::uint32_t j = 0; j <= ny; ++j)
      for (std::uint32_t i = 0; i <= nx; ++i)
        {
          const double x = x0 + i * h, y = y0 + j * h;
          s.vertices.insert(s.vertices.end(), {x, y, z(x, y)});
        }
    for (std::uint32_t j = 0; j < ny; ++j)
      for (std::uint32_t i = 0; i < nx; ++i)
        {
          const std::uint32_t v = j * (nx + 1) + i;
          s.triangles.insert(s.triangles.end(), {v, v + 1, v + nx + 2, v, v + nx + 2, v + nx + 1});
        }
    return s;
  }

  Surface planar_grid(double x0, double y0, double h, std::uint32_t nx, std::uint32_t ny)
  {
    return grid_surface(x0, y0, h, nx, ny, [](double, double) { return 0.0; });
  }

  template <typename Field>
  void set_field(Surface &s, Field k)
  {
    s.stiffness.resize(s.vertices.size() / 3);
    for (std::size_t v = 0; v < s.stiffness.size(); ++v)
      s.stiffness[v] = k(s.x(v));
  }

  // A bumpy surface with a varied map [N/m]: something a rib's panel could look like.
  Surface bumpy_design()
  {
    Surface s = grid_surface(-0.05, -0.04, 0.004, 25, 20, [](double x, double y) { return 0.01 * std::sin(40 * x) * y; });
    set_field(s, [](const double *x) { return 2e4 + 1e4 * std::cos(60 * x[0]) + 3e5 * x[2]; });
    return s;
  }

  void same_map_is_identity()
  {
    const Surface            a = bumpy_design();
    const mrt::MapComparison c = mrt::compare_maps(a.map(), a.map());
    ENSURE(c.rule == mrt::MatchRule::identity);
    ENSURE(c.compared_count == a.stiffness.size());
    ENSURE(c.beyond_noise_count == 0);
    ENSURE(c.max_match_distance == 0.0);
    ENSURE(c.ratio_min == 1.0 && c.ratio_median == 1.0 && c.ratio_max == 1.0);
    double largest = 0.0;
    for (std::size_t v = 0; v < a.stiffness.size(); ++v)
      largest = std::max({largest, std::abs(c.difference[v]), std::abs(c.percent[v])});
    ENSURE(largest == 0.0);
  }

  void scaled_map_is_thirty_percent()
  {
    const Surface a = bumpy_design();
    Surface       b = a;
    for (double &k : b.stiffness)
      k *= 1.3;
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map());
    ENSURE(c.rule == mrt::MatchRule::identity);
    ENSURE(c.compared_count == a.stiffness.size());
    ENSURE(c.beyond_noise_count == a.stiffness.size());
    double worst = 0.0;
    for (std::size_t v = 0; v < a.stiffness.size(); ++v)
      {
        worst = std::max(worst, std::abs(c.percent[v] - 30.0));
        ENSURE_RELATIVE(c.difference[v], 0.3 * a.stiffness[v], 1e-12);
      }
    std::printf("B = 1.3 A: |%% - 30| <= %.3g at every vertex\n", worst);
    ENSURE(worst <= 1e-12);
    ENSURE_NEAR(c.ratio_min, 1.3, 1e-14);
    ENSURE_NEAR(c.ratio_median, 1.3, 1e-14);
    ENSURE_NEAR(c.ratio_max, 1.3, 1e-14);
    ENSURE(c.largest.size() == 10);
  }

  // Half the vertices 0.5 % stiffer (within the 1 % floor), the others 2 %, and vertex 77 softer by
  // 40 %: the largest difference, listed first with its position and both values.
  void noise_floor_and_largest()
  {
    const Surface a = bumpy_design();
    Surface       b = a;
    for (std::size_t v = 0; v < b.stiffness.size(); ++v)
      b.stiffness[v] *= v % 2 ? 1.02 : 1.005;
    b.stiffness[77] = 0.6 * a.stiffness[77];
    mrt::ComparisonOptions options;
    options.largest_count          = 3;
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map(), options);
    const std::size_t        odd = a.stiffness.size() / 2; // 77 is odd: still beyond the floor
    ENSURE(c.beyond_noise_count == odd);
    ENSURE(c.largest.size() == 3);
    ENSURE(c.largest[0].vertex == 77);
    ENSURE_NEAR(c.largest[0].percent, -40.0, 1e-12);
    ENSURE(c.largest[0].a == a.stiffness[77] && c.largest[0].b == b.stiffness[77]);
    ENSURE(c.largest[0].position[0] == a.x(77)[0] && c.largest[0].position[2] == a.x(77)[2]);
    for (int k = 1; k < 3; ++k)
      ENSURE(c.largest[k].vertex % 2 == 1 && std::abs(c.largest[k].percent - 2.0) <= 1e-12);
    ENSURE_NEAR(c.ratio_min, 0.6, 1e-15);
    ENSURE_NEAR(c.ratio_max, 1.02, 1e-15);
    options.noise_floor_percent = 0.1;
    ENSURE(mrt::compare_maps(a.map(), b.map(), options).beyond_noise_count == a.stiffness.size());
  }

  void vertices_without_value()
  {
    const Surface a0 = bumpy_design();
    Surface       a = a0, b = a0;
    a.stiffness[3] = 0.0;
    b.stiffness[5] = 0.0;
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map());
    ENSURE(c.a_without_value == 1 && c.b_without_value == 1);
    ENSURE(c.compared_count == a.stiffness.size() - 2);
    ENSURE(!c.compared[3] && !c.compared[5] && c.compared[4]);

    // The closest-point rule blends only B's vertices with a value: inside a triangle with weights
    // (1/2, 1/4, 1/4) and no value at the third vertex, (k0 / 2 + k1 / 4) / (3 / 4); at that vertex
    // itself, nothing.
    const double              tri_x[9] = {0, 0, 0, 0.01, 0, 0, 0, 0.01, 0}, tri_k[3] = {1e4, 2e4, 0};
    const std::uint32_t       tri[3]   = {0, 1, 2};
    const double              at_x[6]  = {0.0025, 0.0025, 0, 0, 0.01, 0}, at_k[2] = {1e4, 1e4};
    const mrt::MapComparison  p        = mrt::compare_maps({at_x, 2, nullptr, 0, at_k}, {tri_x, 3, tri, 1, tri_k});
    ENSURE(p.rule == mrt::MatchRule::closest_point);
    ENSURE_RELATIVE(p.b_at_a[0], (1e4 / 2 + 2e4 / 4) / 0.75, 1e-14);
    ENSURE(p.b_at_a[1] == 0.0 && p.b_without_value == 1 && p.compared_count == 1);
    // 1e-15 m from that corner the far corners' weights are 1e-13: rounding, not a value to borrow.
    const double near_x[3] = {1e-15, 0.01 - 2e-15, 0};
    const mrt::MapComparison q = mrt::compare_maps({near_x, 1, nullptr, 0, at_k}, {tri_x, 3, tri, 1, tri_k});
    ENSURE(q.b_without_value == 1 && q.compared_count == 0);
  }

  double linear_field(const double *x) { return 3e4 + 2e5 * x[0] - 1.5e5 * x[1] + 7e5 * x[2]; }

  // A on a 2 mm grid, B on a 3.1 mm one over a larger rectangle of the same plane (z = 0).
  void retriangulated_plane_reproduces_linear_field()
  {
    Surface a = planar_grid(-0.04, -0.03, 0.002, 40, 30);
    Surface b = planar_grid(-0.0411, -0.0313, 0.0031, 28, 22);
    set_field(a, linear_field);
    set_field(b, linear_field);
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map());
    ENSURE(c.rule == mrt::MatchRule::closest_point);
    ENSURE(c.a_vertex_count == 41 * 31 && c.b_vertex_count == 29 * 23);
    ENSURE(c.compared_count == a.stiffness.size());
    double worst = 0.0;
    for (std::size_t v = 0; v < a.stiffness.size(); ++v)
      worst = std::max(worst, std::abs(c.b_at_a[v] - a.stiffness[v]) / a.stiffness[v]);
    std::printf("another triangulation, linear field: relative error <= %.3g, match distance <= %.3g m\n", worst,
                c.max_match_distance);
    ENSURE(worst <= 1e-12);
    ENSURE(c.max_match_distance <= 1e-15);
    ENSURE(c.beyond_noise_count == 0);
  }

  // k = k0 (1 + q x^2) on B: linear interpolation over a triangle whose x extent is h errs by
  // k0 q sum_k w_k (x_k - x)^2, a variance of the x_k about x, at most k0 q h^2 / 4 (reached at the
  // midpoint of an edge spanning h).
  void retriangulated_plane_quadratic_field_within_bound()
  {
    const double k0 = 2e4, q = 400.0, h = 0.003;
    const auto   field = [&](const double *x) { return k0 * (1.0 + q * x[0] * x[0]); };
    Surface      a     = planar_grid(-0.03, -0.03, 0.0015, 40, 40); // its vertices include B's edge midpoints
    Surface      b     = planar_grid(-0.03, -0.03, h, 20, 20);
    a.vertices.push_back(0.0); // one vertex more: the counts differ even where the grids nest
    a.vertices.push_back(0.0);
    a.vertices.push_back(0.0);
    set_field(a, field);
    set_field(b, field);
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map());
    ENSURE(c.rule == mrt::MatchRule::closest_point);
    double worst = 0.0;
    for (std::size_t v = 0; v < a.stiffness.size(); ++v)
      worst = std::max(worst, c.b_at_a[v] - a.stiffness[v]);
    const double bound = k0 * q * h * h / 4;
    std::printf("another triangulation, quadratic field: largest error %.6g N/m, bound %.6g N/m\n", worst, bound);
    ENSURE(worst <= bound * (1 + 1e-9));
    ENSURE(worst >= bound * (1 - 1e-9));
  }

  void shifted_surface_reports_distance()
  {
    const double d = 0.0007;
    Surface      a = planar_grid(-0.02, -0.02, 0.002, 20, 20);
    Surface      b = a;
    for (std::size_t v = 0; v < b.vertices.size() / 3; ++v)
      b.vertices[3 * v + 2] += d;
    set_field(a, linear_field);
    set_field(b, [](const double *x) { return linear_field(x) - 7e5 * 0.0007; }); // the same field in x, y
    const mrt::MapComparison c = mrt::compare_maps(a.map(), b.map());
    ENSURE(c.rule == mrt::MatchRule::closest_point);
    ENSURE_NEAR(c.max_match_distance, d, 1e-15);
    ENSURE_NEAR(c.p95_match_distance, d, 1e-15);
    double worst = 0.0;
    for (std::size_t v = 0; v < a.stiffness.size(); ++v)
      worst = std::max(worst, std::abs(c.percent[v]));
    std::printf("shifted by %g m along the normal: match distance %.9g m, |%%| <= %.3g\n", d, c.max_match_distance,
                worst);
    ENSURE(worst <= 1e-10);
    // A shift below the tolerance keeps the identity rule.
    for (std::size_t v = 0; v < b.vertices.size() / 3; ++v)
      b.vertices[3 * v + 2] = a.vertices[3 * v + 2] + 5e-10;
    ENSURE(mrt::compare_maps(a.map(), b.map()).rule == mrt::MatchRule::identity);
  }

  // The grid against the closest point over every triangle, on a curved surface.
  void grid_equals_search_over_every_triangle()
  {
    const Surface s = grid_surface(-0.05, -0.05, 0.005, 20, 20, [](double x, double y) { return 20 * (x * x - y * y); });
    const mrt::ClosestPointGrid grid(s.map());
    std::mt19937_64             random(7);
    std::uniform_real_distribution<double> u(-0.12, 0.12);
    double                                 worst = 0.0;
    for (int k = 0; k < 2000; ++k)
      {
        const double scale = k < 1000 ? 0.3 : 1.0; // near the surface, then up to twice its size away
        const double p[3]  = {u(random), u(random), scale * u(random)};
        double       exact = 1e300;
        for (std::uint32_t t = 0; t < s.triangles.size() / 3; ++t)
          {
            // The closest point of one triangle alone, through a one-triangle grid.
            const std::uint32_t   tri[3] = {s.triangles[3 * t], s.triangles[3 * t + 1], s.triangles[3 * t + 2]};
            const mrt::SurfaceMap one{s.vertices.data(), s.vertices.size() / 3, tri, 1, nullptr};
            mrt::ClosestPointGrid::Hit hit;
            mrt::ClosestPointGrid(one).closest(p, hit);
            exact = std::min(exact, hit.distance);
          }
        mrt::ClosestPointGrid::Hit hit;
        ENSURE(grid.closest(p, hit));
        worst = std::max(worst, std::abs(hit.distance - exact));
        // The weights give the point at that distance.
        const std::uint32_t *tri = &s.triangles[3 * hit.triangle];
        double               q[3] = {0, 0, 0};
        for (int i = 0; i < 3; ++i)
          for (int dd = 0; dd < 3; ++dd)
            q[dd] += hit.weights[i] * s.x(tri[i])[dd];
        ENSURE_NEAR(std::sqrt((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                              (q[2] - p[2]) * (q[2] - p[2])),
                    hit.distance, 1e-14);
      }
    std::printf("grid against every triangle: 2000 points, largest distance difference %.3g m\n", worst);
    ENSURE(worst <= 1e-15);
  }

  void large_maps_match_quickly()
  {
    Surface a = planar_grid(-0.1, -0.1, 0.2 / 316, 316, 316); // 100,489 vertices
    Surface b = planar_grid(-0.1003, -0.1003, 0.2006 / 300, 300, 300);
    const auto field = [](const double *x) { return 3e4 + 1e5 * x[0] + 5e4 * x[1]; }; // > 0 on it
    set_field(a, field);
    set_field(b, field);
    const auto               start = std::chrono::steady_clock::now();
    const mrt::MapComparison c     = mrt::compare_maps(a.map(), b.map());
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%zu vertices against %zu (closest point): %.3f s, ratio %.15g .. %.15g\n", a.stiffness.size(),
                b.stiffness.size(), seconds, c.ratio_min, c.ratio_max);
    ENSURE(c.compared_count == a.stiffness.size());
    ENSURE(std::abs(c.ratio_min - 1.0) <= 1e-12 && std::abs(c.ratio_max - 1.0) <= 1e-12);
    ENSURE(seconds < 20.0); // about 0.1 s; a search over every pair would take hours
  }
} // namespace

int main()
{
  same_map_is_identity();
  scaled_map_is_thirty_percent();
  noise_floor_and_largest();
  vertices_without_value();
  retriangulated_plane_reproduces_linear_field();
  retriangulated_plane_quadratic_field_within_bound();
  shifted_surface_reports_distance();
  grid_equals_search_over_every_triangle();
  large_maps_match_quickly();
  return test::finish("test_map_comparison");
}
