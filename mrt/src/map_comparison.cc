#include <mrt/map_comparison.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace mrt
{
  namespace
  {
    const double infinity = std::numeric_limits<double>::infinity();

    double dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

    double distance(const double a[3], const double b[3])
    {
      const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
      return std::sqrt(dot(d, d));
    }

    // The closest point of segment [a, b] to p: its parameter t in [0, 1] along a -> b.
    double closest_on_segment(const double p[3], const double a[3], const double b[3])
    {
      const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const double d[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
      const double ee   = dot(e, e);
      return ee > 0.0 ? std::clamp(dot(d, e) / ee, 0.0, 1.0) : 0.0;
    }

    // The closest point of triangle (x0, x1, x2) to p as barycentric weights, and its distance.
    // Inside the triangle it is p's projection onto its plane; otherwise it lies on an edge, the
    // nearest of the three (a degenerate triangle is its edges only).
    double closest_on_triangle(const double p[3], const double *x[3], double weights[3])
    {
      const double e1[3] = {x[1][0] - x[0][0], x[1][1] - x[0][1], x[1][2] - x[0][2]};
      const double e2[3] = {x[2][0] - x[0][0], x[2][1] - x[0][1], x[2][2] - x[0][2]};
      const double d[3]  = {p[0] - x[0][0], p[1] - x[0][1], p[2] - x[0][2]};
      const double g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2);
      const double det = g11 * g22 - g12 * g12;
      if (det > 1e-24 * g11 * g22)
        {
          const double s = (g22 * dot(d, e1) - g12 * dot(d, e2)) / det;
          const double t = (g11 * dot(d, e2) - g12 * dot(d, e1)) / det;
          if (s >= 0.0 && t >= 0.0 && s + t <= 1.0)
            {
              weights[0] = 1.0 - s - t, weights[1] = s, weights[2] = t;
              const double q[3] = {x[0][0] + s * e1[0] + t * e2[0], x[0][1] + s * e1[1] + t * e2[1],
                                   x[0][2] + s * e1[2] + t * e2[2]};
              return distance(p, q);
            }
        }
      double best = infinity;
      for (int k = 0; k < 3; ++k)
        {
          const int    from = k, to = (k + 1) % 3;
          const double t    = closest_on_segment(p, x[from], x[to]);
          const double q[3] = {x[from][0] + t * (x[to][0] - x[from][0]), x[from][1] + t * (x[to][1] - x[from][1]),
                               x[from][2] + t * (x[to][2] - x[from][2])};
          const double dq   = distance(p, q);
          if (dq < best)
            {
              best              = dq;
              weights[from]     = 1.0 - t;
              weights[to]       = t;
              weights[3 - from - to] = 0.0;
            }
        }
      return best;
    }

    const double *vertex(const SurfaceMap &m, std::uint32_t v) { return m.vertices + 3 * std::size_t(v); }
  } // namespace

  const char *match_rule_name(MatchRule rule) { return rule == MatchRule::identity ? "identity" : "closest point"; }

  namespace
  {
    // The bounding box of triangle t.
    void triangle_box(const SurfaceMap &m, std::size_t t, double lower[3], double upper[3])
    {
      for (int d = 0; d < 3; ++d)
        lower[d] = infinity, upper[d] = -infinity;
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d)
          {
            const double x = vertex(m, m.triangles[3 * t + k])[d];
            lower[d] = std::min(lower[d], x), upper[d] = std::max(upper[d], x);
          }
    }
  } // namespace

  ClosestPointGrid::ClosestPointGrid(const SurfaceMap &surface) : surface_(surface)
  {
    if (surface.triangle_count == 0)
      return;
    size_cells();
    list_triangles();
  }

  // The grid spans the bounding box of B's triangles. Its cell is about a triangle's size (the mean
  // of their largest bounding-box extents), so a cell lists a few triangles and a point near the
  // surface finds its closest one in the first ring or two of cells; the cell count is capped at a
  // few per triangle, which bounds the memory for a thin or sparse surface.
  void ClosestPointGrid::size_cells()
  {
    const std::size_t nt = surface_.triangle_count;
    double lower[3] = {infinity, infinity, infinity}, upper[3] = {-infinity, -infinity, -infinity};
    double extent_sum = 0.0;
    for (std::size_t t = 0; t < nt; ++t)
      {
        double tl[3], tu[3];
        triangle_box(surface_, t, tl, tu);
        extent_sum += std::max({tu[0] - tl[0], tu[1] - tl[1], tu[2] - tl[2]});
        for (int d = 0; d < 3; ++d)
          lower[d] = std::min(lower[d], tl[d]), upper[d] = std::max(upper[d], tu[d]);
      }
    const double box = std::max({upper[0] - lower[0], upper[1] - lower[1], upper[2] - lower[2]});
    cell_size_       = extent_sum > 0.0 ? extent_sum / double(nt) : (box > 0.0 ? box : 1.0);
    const auto cells_along = [&](int d) { return std::max(1.0, std::ceil((upper[d] - lower[d]) / cell_size_)); };
    const double max_cells = 4.0 * double(nt) + 64.0;
    for (double count; (count = cells_along(0) * cells_along(1) * cells_along(2)) > max_cells;)
      cell_size_ *= std::cbrt(count / max_cells) * 1.01;
    for (int d = 0; d < 3; ++d)
      origin_[d] = lower[d], cells_[d] = std::size_t(cells_along(d));
  }

  // Each triangle into every cell its bounding box meets: counted, then filled (compressed rows).
  void ClosestPointGrid::list_triangles()
  {
    const std::size_t cell_count = cells_[0] * cells_[1] * cells_[2];
    cell_start_.assign(cell_count + 1, 0);
    for (int pass = 0; pass < 2; ++pass)
      {
        std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
        if (pass == 1)
          cell_triangles_.resize(cell_start_.back());
        for (std::size_t t = 0; t < surface_.triangle_count; ++t)
          {
            double      tl[3], tu[3];
            std::size_t lo[3], hi[3], c[3];
            triangle_box(surface_, t, tl, tu);
            cell_of(tl, lo);
            cell_of(tu, hi);
            for (c[2] = lo[2]; c[2] <= hi[2]; ++c[2])
              for (c[1] = lo[1]; c[1] <= hi[1]; ++c[1])
                for (c[0] = lo[0]; c[0] <= hi[0]; ++c[0])
                  {
                    const std::size_t cell = cell_index(c);
                    if (pass == 0)
                      ++cell_start_[cell + 1];
                    else
                      cell_triangles_[fill[cell]++] = std::uint32_t(t);
                  }
          }
        if (pass == 0)
          for (std::size_t cell = 0; cell < cell_count; ++cell)
            cell_start_[cell + 1] += cell_start_[cell];
      }
  }

  void ClosestPointGrid::cell_of(const double point[3], std::size_t c[3]) const
  {
    for (int d = 0; d < 3; ++d)
      {
        const double at = std::floor((point[d] - origin_[d]) / cell_size_); // clamped before the cast
        c[d]            = at <= 0.0 ? 0 : std::size_t(std::min(double(cells_[d] - 1), at));
      }
  }

  void ClosestPointGrid::search_cell(const std::size_t c[3], const double point[3], Hit &best, bool &found) const
  {
    const std::size_t cell = cell_index(c);
    for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k)
      {
        const std::uint32_t  t   = cell_triangles_[k];
        const std::uint32_t *tri = surface_.triangles + 3 * std::size_t(t);
        const double        *x[3] = {vertex(surface_, tri[0]), vertex(surface_, tri[1]), vertex(surface_, tri[2])};
        double               weights[3];
        const double         d = closest_on_triangle(point, x, weights);
        if (!found || d < best.distance || (d == best.distance && t < best.triangle))
          {
            found         = true;
            best.triangle = t;
            best.distance = d;
            std::copy(weights, weights + 3, best.weights);
          }
      }
  }

  // A lower bound on the distance from `point` to any cell outside the box of cells within `ring`
  // of c (c: the point's cell, clamped to the grid): the distance to the nearest face of that box
  // behind which cells remain; infinity once the box holds the whole grid.
  double ClosestPointGrid::distance_outside_shell(const double point[3], const std::size_t c[3],
                                                  std::size_t ring) const
  {
    double bound = infinity;
    for (int d = 0; d < 3; ++d)
      {
        if (c[d] > ring)
          bound = std::min(bound, point[d] - (origin_[d] + double(c[d] - ring) * cell_size_));
        if (c[d] + ring + 1 < cells_[d])
          bound = std::min(bound, origin_[d] + double(c[d] + ring + 1) * cell_size_ - point[d]);
      }
    return bound;
  }

  // The cells at ring distance exactly `ring` from c (the inner ones were searched before): whole
  // rows where the row itself is on the shell, else the row's two ends.
  void ClosestPointGrid::search_ring(const std::size_t c[3], std::size_t ring, const double point[3], Hit &best,
                                     bool &found) const
  {
    std::size_t lo[3], hi[3], at[3];
    for (int d = 0; d < 3; ++d)
      lo[d] = c[d] > ring ? c[d] - ring : 0, hi[d] = std::min(cells_[d] - 1, c[d] + ring);
    const auto offset = [](std::size_t a, std::size_t b) { return a > b ? a - b : b - a; };
    for (at[2] = lo[2]; at[2] <= hi[2]; ++at[2])
      for (at[1] = lo[1]; at[1] <= hi[1]; ++at[1])
        if (std::max(offset(at[2], c[2]), offset(at[1], c[1])) == ring)
          {
            for (at[0] = lo[0]; at[0] <= hi[0]; ++at[0])
              search_cell(at, point, best, found);
          }
        else // ring > 0 here
          {
            if (c[0] >= ring)
              at[0] = c[0] - ring, search_cell(at, point, best, found);
            if (c[0] + ring < cells_[0])
              at[0] = c[0] + ring, search_cell(at, point, best, found);
          }
  }

  // Rings of cells around the point's cell, nearest first, until the best triangle found is no
  // farther than every cell not yet searched.
  bool ClosestPointGrid::closest(const double point[3], Hit &hit) const
  {
    if (cell_start_.empty())
      return false;
    std::size_t c[3];
    cell_of(point, c);
    bool found = false;
    for (std::size_t ring = 0;; ++ring)
      {
        search_ring(c, ring, point, hit, found);
        const double bound = distance_outside_shell(point, c, ring);
        if ((found && hit.distance <= bound) || bound == infinity)
          return found;
      }
  }

  namespace
  {
    // Whether B is A's surface: the same vertex count, every vertex within the tolerance.
    bool same_surface(const SurfaceMap &a, const SurfaceMap &b, double tolerance)
    {
      if (a.vertex_count != b.vertex_count)
        return false;
      for (std::uint32_t v = 0; v < a.vertex_count; ++v)
        if (!(distance(vertex(a, v), vertex(b, v)) <= tolerance))
          return false;
      return true;
    }

    // A barycentric weight at or below it is rounding: a point at a corner without a value must not
    // take the far corners' values through weights of 1e-16.
    const double negligible_weight = 1e-12;

    // B's stiffness at a point of its triangle: the barycentric blend of the triangle's vertices that
    // have a value, the weights renormalized over them; 0 when no corner of non-negligible weight has one.
    double blend(const SurfaceMap &b, const ClosestPointGrid::Hit &hit)
    {
      double sum = 0.0, weight = 0.0;
      for (int k = 0; k < 3; ++k)
        {
          const double value = b.stiffness[b.triangles[3 * std::size_t(hit.triangle) + k]];
          if (value > 0.0 && hit.weights[k] > negligible_weight)
            sum += hit.weights[k] * value, weight += hit.weights[k];
        }
      return weight > 0.0 ? sum / weight : 0.0;
    }

    // B read at every vertex of A by the rule: match_distance and b_at_a.
    void match(const SurfaceMap &a, const SurfaceMap &b, MapComparison &out)
    {
      out.match_distance.assign(a.vertex_count, 0.0);
      out.b_at_a.assign(a.vertex_count, 0.0);
      if (out.rule == MatchRule::identity)
        {
          for (std::uint32_t v = 0; v < a.vertex_count; ++v)
            {
              out.match_distance[v] = distance(vertex(a, v), vertex(b, v));
              out.b_at_a[v]         = b.stiffness[v];
            }
          return;
        }
      const ClosestPointGrid grid(b);
      for (std::uint32_t v = 0; v < a.vertex_count; ++v)
        {
          ClosestPointGrid::Hit hit;
          if (!grid.closest(vertex(a, v), hit))
            {
              out.match_distance[v] = infinity; // B has no surface to read
              continue;
            }
          out.match_distance[v] = hit.distance;
          out.b_at_a[v]         = blend(b, hit);
        }
    }

    double median_of_sorted(const std::vector<double> &x)
    {
      const std::size_t n = x.size();
      return n == 0 ? 0.0 : 0.5 * (x[(n - 1) / 2] + x[n / 2]);
    }

    void match_statistics(MapComparison &out)
    {
      std::vector<double> d = out.match_distance;
      if (d.empty())
        return;
      std::sort(d.begin(), d.end());
      out.max_match_distance = d.back();
      out.p95_match_distance = d[std::min(d.size() - 1, std::size_t(0.95 * double(d.size() - 1) + 0.5))];
    }

    // The differences where both have a value, the ratio's statistics and the count beyond the floor.
    void differences(const SurfaceMap &a, MapComparison &out)
    {
      const std::size_t n = a.vertex_count;
      out.compared.assign(n, 0);
      out.difference.assign(n, 0.0);
      out.percent.assign(n, 0.0);
      std::vector<double> ratios;
      for (std::size_t v = 0; v < n; ++v)
        {
          const double ka = a.stiffness[v], kb = out.b_at_a[v];
          if (!(ka > 0.0))
            {
              ++out.a_without_value;
              continue;
            }
          if (!(kb > 0.0))
            {
              ++out.b_without_value;
              continue;
            }
          out.compared[v]   = 1;
          out.difference[v] = kb - ka;
          out.percent[v]    = 100.0 * (kb - ka) / ka;
          ratios.push_back(kb / ka);
          if (std::abs(out.percent[v]) > out.noise_floor_percent)
            ++out.beyond_noise_count;
        }
      out.compared_count = ratios.size();
      std::sort(ratios.begin(), ratios.end());
      if (!ratios.empty())
        out.ratio_min = ratios.front(), out.ratio_median = median_of_sorted(ratios), out.ratio_max = ratios.back();
    }

    void largest_differences(const SurfaceMap &a, std::size_t count, MapComparison &out)
    {
      std::vector<std::uint32_t> order;
      for (std::uint32_t v = 0; v < a.vertex_count; ++v)
        if (out.compared[v])
          order.push_back(v);
      const auto larger = [&out](std::uint32_t u, std::uint32_t v) {
        const double pu = std::abs(out.percent[u]), pv = std::abs(out.percent[v]);
        return pu > pv || (pu == pv && u < v);
      };
      count = std::min(count, order.size());
      std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(count), order.end(), larger);
      for (std::size_t k = 0; k < count; ++k)
        {
          const std::uint32_t v = order[k];
          VertexDifference    d;
          d.vertex = v;
          std::copy(vertex(a, v), vertex(a, v) + 3, d.position);
          d.a              = a.stiffness[v];
          d.b              = out.b_at_a[v];
          d.percent        = out.percent[v];
          d.match_distance = out.match_distance[v];
          out.largest.push_back(d);
        }
    }
  } // namespace

  MapComparison compare_maps(const SurfaceMap &a, const SurfaceMap &b, const ComparisonOptions &options)
  {
    MapComparison out;
    out.a_vertex_count      = a.vertex_count;
    out.b_vertex_count      = b.vertex_count;
    out.noise_floor_percent = options.noise_floor_percent;
    out.rule = same_surface(a, b, options.same_position_tolerance) ? MatchRule::identity : MatchRule::closest_point;
    match(a, b, out);
    match_statistics(out);
    differences(a, out);
    largest_differences(a, options.largest_count, out);
    return out;
  }
} // namespace mrt
