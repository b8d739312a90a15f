#include "scene/display_surface.h"

#include <mrt/patch_profile.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace modal_haptics
{
  namespace
  {
    double distance(const meshing::Point3 &a, const meshing::Point3 &b)
    {
      return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                       (a[2] - b[2]) * (a[2] - b[2]));
    }

    std::vector<double> lumped_vertex_areas(const ContactSurface &s)
    {
      std::vector<double> area(s.n_vertices(), 0.);
      for (const auto &t : s.triangles)
        {
          const auto &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
          const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
          const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
          const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
          const double third = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) / 6.;
          for (const unsigned int i : t)
            area[i] += third;
        }
      return area;
    }

    // A uniform grid of cell size rho over the vertices: the neighbours within rho of a vertex lie
    // in the 27 cells around it.
    class VertexGrid
    {
    public:
      VertexGrid(const std::vector<meshing::Point3> &points, const double cell_size)
        : points(points), h(cell_size)
      {
        for (unsigned int i = 0; i < points.size(); ++i)
          cells[key(cell_of(points[i]))].push_back(i);
      }

      template <typename Visitor>
      void for_each_within(const meshing::Point3 &p, const double radius, Visitor visit) const
      {
        const auto c = cell_of(p);
        for (long dx = -1; dx <= 1; ++dx)
          for (long dy = -1; dy <= 1; ++dy)
            for (long dz = -1; dz <= 1; ++dz)
              {
                const auto it = cells.find(key({{c[0] + dx, c[1] + dy, c[2] + dz}}));
                if (it == cells.end())
                  continue;
                for (const unsigned int j : it->second)
                  {
                    const double d = distance(p, points[j]);
                    if (d < radius)
                      visit(j, d);
                  }
              }
      }

    private:
      std::array<long, 3> cell_of(const meshing::Point3 &p) const
      {
        return {{long(std::floor(p[0] / h)), long(std::floor(p[1] / h)), long(std::floor(p[2] / h))}};
      }
      static long long key(const std::array<long, 3> &c)
      {
        return ((long long)(c[0] & 0x1FFFFF) << 42) | ((long long)(c[1] & 0x1FFFFF) << 21) | (c[2] & 0x1FFFFF);
      }

      const std::vector<meshing::Point3>               &points;
      double                                            h;
      std::unordered_map<long long, std::vector<unsigned int>> cells;
    };

    void build_vertex_triangles(ContactSurface &s)
    {
      s.vertex_triangle_offsets.assign(s.n_vertices() + 1, 0);
      for (const auto &t : s.triangles)
        for (const unsigned int i : t)
          ++s.vertex_triangle_offsets[i + 1];
      for (unsigned int v = 0; v < s.n_vertices(); ++v)
        s.vertex_triangle_offsets[v + 1] += s.vertex_triangle_offsets[v];
      s.vertex_triangles.resize(s.vertex_triangle_offsets.back());
      std::vector<unsigned int> next(s.vertex_triangle_offsets.begin(), s.vertex_triangle_offsets.end() - 1);
      for (unsigned int t = 0; t < s.triangles.size(); ++t)
        for (const unsigned int i : s.triangles[t])
          s.vertex_triangles[next[i]++] = t;
    }

    double patch_density(const meshing::Point3 &centre, const meshing::Point3 &x, const double rho)
    {
      return mrt::patch_profile(distance(centre, x) / rho);
    }

    void build_patches(ContactSurface &s)
    {
      const double rho = s.patch_radius;
      s.patch_offsets.assign(1, 0);
      s.max_patch_size = 1;
      if (rho <= 0.)
        {
          for (unsigned int v = 0; v < s.n_vertices(); ++v)
            {
              s.patch_vertices.push_back(v);
              s.patch_weights.push_back(1.);
              s.patch_offsets.push_back(s.patch_vertices.size());
            }
          return;
        }
      const VertexGrid grid(s.vertices, rho);
      std::vector<std::pair<unsigned int, double>> patch;
      for (unsigned int v = 0; v < s.n_vertices(); ++v)
        {
          patch.clear();
          grid.for_each_within(s.vertices[v], rho, [&](unsigned int j, double d) {
            patch.emplace_back(j, s.vertex_area[j] * mrt::patch_profile(d / rho));
          });
          // The active vertex first, the others by index: a reproducible order.
          std::sort(patch.begin(), patch.end(), [v](const auto &a, const auto &b) {
            return (a.first == v) != (b.first == v) ? a.first == v : a.first < b.first;
          });
          double sum = 0.;
          for (const auto &e : patch)
            sum += e.second;
          for (const auto &e : patch)
            {
              s.patch_vertices.push_back(e.first);
              s.patch_weights.push_back(e.second / sum);
            }
          s.patch_offsets.push_back(s.patch_vertices.size());
          s.max_patch_size = std::max<unsigned int>(s.max_patch_size, patch.size());
        }
    }
  } // namespace

  ContactSurface make_display_surface(const meshing::DisplaySurface                &surface,
                                      const std::vector<meshing::VolumeOfInterest> &volumes_of_interest,
                                      const double length_unit,
                                      const double patch_radius)
  {
    ContactSurface s;
    s.triangles    = surface.triangles;
    s.patch_radius = patch_radius;
    s.region.assign(surface.vertices.size(), 0);
    for (unsigned int v = 0; v < surface.vertices.size(); ++v)
      {
        const auto &p = surface.vertices[v];
        s.vertices.push_back({{p[0] * length_unit, p[1] * length_unit, p[2] * length_unit}});
        // A vertex on the VOI's boundary belongs to it: the VOI mesh is fine up to there.
        for (unsigned int k = 0; k < volumes_of_interest.size(); ++k)
          if (volumes_of_interest[k].contains(p, 1e-9))
            {
              s.region[v] = k + 1;
              break;
            }
      }
    s.vertex_area = lumped_vertex_areas(s);
    build_patches(s);
    build_vertex_triangles(s);
    return s;
  }

  std::vector<SurfacePoint> patch_quadrature(const ContactSurface &s, const unsigned int vertex)
  {
    const meshing::Point3 &centre = s.vertices[vertex];
    const double           rho    = s.patch_radius;
    if (rho <= 0.)
      return {{centre, 1.}};

    // Every triangle around a patch vertex: that covers the disk of radius rho, also where the
    // triangles are larger than rho (then the patch is v alone and the disk lies in v's star).
    std::vector<unsigned int> triangles;
    for (unsigned int k = s.patch_offsets[vertex]; k < s.patch_offsets[vertex + 1]; ++k)
      {
        const unsigned int j = s.patch_vertices[k];
        triangles.insert(triangles.end(), s.vertex_triangles.begin() + s.vertex_triangle_offsets[j],
                         s.vertex_triangles.begin() + s.vertex_triangle_offsets[j + 1]);
      }
    std::sort(triangles.begin(), triangles.end());
    triangles.erase(std::unique(triangles.begin(), triangles.end()), triangles.end());

    // Degree-2 rule on a triangle: three points at barycentric (2/3, 1/6, 1/6) and permutations.
    const double rule[3][3] = {{2. / 3., 1. / 6., 1. / 6.}, {1. / 6., 2. / 3., 1. / 6.}, {1. / 6., 1. / 6., 2. / 3.}};
    std::vector<SurfacePoint> points;
    double                    sum = 0.;
    for (const unsigned int t : triangles)
      {
        const auto &a = s.vertices[s.triangles[t][0]], &b = s.vertices[s.triangles[t][1]],
                   &c = s.vertices[s.triangles[t][2]];
        const double longest  = std::max({distance(a, b), distance(b, c), distance(c, a)});
        const unsigned int m  = std::min<unsigned int>(32, std::max<unsigned int>(1, std::ceil(2. * longest / rho)));
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        const double sub_area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) / (m * m);
        // The m^2 sub-triangles of a regular split, in the (s, t) parameters of the triangle: the
        // "upward" ones (i, j), (i+1, j), (i, j+1) and the "downward" ones (i+1, j), (i+1, j+1), (i, j+1).
        const auto add_sub_triangle = [&](const std::array<std::array<double, 2>, 3> &corners) {
          for (const auto &weights : rule)
            {
              double st[2] = {0., 0.};
              for (unsigned int k = 0; k < 3; ++k)
                for (unsigned int d = 0; d < 2; ++d)
                  st[d] += weights[k] * corners[k][d];
              const meshing::Point3 x = {{a[0] + st[0] * u[0] + st[1] * v[0], a[1] + st[0] * u[1] + st[1] * v[1],
                                          a[2] + st[0] * u[2] + st[1] * v[2]}};
              const double w = patch_density(centre, x, rho) * sub_area / 3.;
              if (w > 0.)
                points.push_back({x, w}), sum += w;
            }
        };
        for (unsigned int i = 0; i < m; ++i)
          for (unsigned int j = 0; i + j < m; ++j)
            {
              const double s0 = double(i) / m, t0 = double(j) / m, h = 1. / m;
              add_sub_triangle({{{{s0, t0}}, {{s0 + h, t0}}, {{s0, t0 + h}}}});
              if (i + j + 1 < m)
                add_sub_triangle({{{{s0 + h, t0}}, {{s0 + h, t0 + h}}, {{s0, t0 + h}}}});
            }
      }
    for (auto &p : points)
      p.weight /= sum;
    return points;
  }
} // namespace modal_haptics
