// The sliding contact (contact_mode = MODALRT_CONTACT_PROXY): a proxy on the deformed display
// surface that the HIP is coupled to (god-object), moved by Coulomb friction before each impedance
// step. Its load point is its position on its triangle: the barycentric blend of the corners' rows,
// rest positions, normals and residual compliances, so the force and the felt compliance stay
// continuous as it crosses from one vertex's neighbourhood to the next. modalrt.h states the rules;
// the passivity observer of the impedance ticks is here too.
#include "kernel.h"

#include "dense.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>

using namespace modalrt;

namespace modalrt
{
  void closest_point_weights(const double x[3], const double a[3], const double b[3], const double c[3], double w[3])
  {
    auto set = [w](double wa, double wb, double wc) { w[0] = wa, w[1] = wb, w[2] = wc; };
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    for (int d = 0; d < 3; ++d)
      ab[d] = b[d] - a[d], ac[d] = c[d] - a[d], ap[d] = x[d] - a[d], bp[d] = x[d] - b[d], cp[d] = x[d] - c[d];
    const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0)
      return set(1.0, 0.0, 0.0);
    const double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    if (d3 >= 0.0 && d4 <= d3)
      return set(0.0, 1.0, 0.0);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
      return set(1.0 - d1 / (d1 - d3), d1 / (d1 - d3), 0.0);
    const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0.0 && d5 <= d6)
      return set(0.0, 0.0, 1.0);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
      return set(1.0 - d2 / (d2 - d6), 0.0, d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
      {
        const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return set(0.0, 1.0 - t, t);
      }
    const double denominator = 1.0 / (va + vb + vc), v = vb * denominator, t = vc * denominator;
    set(1.0 - v - t, v, t);
  }
} // namespace modalrt

namespace
{
  // The cached row of `vertex` (a corner of the proxy's triangle: always cached).
  const ProxyRow &row_of(const ProxyState &proxy, std::uint32_t vertex)
  {
    for (const ProxyRow &row : proxy.rows)
      if (row.vertex == vertex)
        return row;
    return proxy.rows[0];
  }

  // Deformed corners of the proxy's triangle without the contact's correction (a common offset).
  void deformed_corners(const modalrt_basis &basis, const ProxyState &proxy, double Y[3][3])
  {
    const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.triangle)];
    for (int k = 0; k < 3; ++k)
      {
        const ProxyRow &row = row_of(proxy, corners[k]);
        for (int d = 0; d < 3; ++d)
          Y[k][d] = basis.vertices[3 * std::size_t(corners[k]) + d] + row.u[d];
      }
  }

  // Barycentric change dw (sum 0) whose displacement over triangle Y is the projection of `step` on
  // its plane (least squares over the two edges). False for a degenerate triangle.
  bool barycentric_step(const double Y[3][3], const double step[3], double dw[3])
  {
    double e1[3], e2[3];
    for (int d = 0; d < 3; ++d)
      e1[d] = Y[1][d] - Y[0][d], e2[d] = Y[2][d] - Y[0][d];
    const double a11 = dot3(e1, e1), a12 = dot3(e1, e2), a22 = dot3(e2, e2), det = a11 * a22 - a12 * a12;
    if (!(det > 1e-12 * a11 * a22))
      return false;
    const double b1 = dot3(step, e1), b2 = dot3(step, e2);
    const double s1 = (a22 * b1 - a12 * b2) / det, s2 = (a11 * b2 - a12 * b1) / det;
    dw[0] = -s1 - s2, dw[1] = s1, dw[2] = s2;
    return true;
  }

  // Moves weights w by s dw, s <= 1 the largest that keeps them >= 0; `exit` is the corner that
  // reached 0 first (-1 if the whole step fits).
  double advance(double w[3], const double dw[3], int &exit)
  {
    double s = 1.0;
    exit     = -1;
    for (int k = 0; k < 3; ++k)
      if (dw[k] < 0.0 && w[k] + s * dw[k] < 0.0)
        s = w[k] / -dw[k], exit = k;
    double sum = 0.0;
    for (int k = 0; k < 3; ++k)
      sum += (w[k] = k == exit ? 0.0 : std::max(0.0, w[k] + s * dw[k]));
    for (int k = 0; k < 3; ++k)
      w[k] /= sum;
    return s;
  }
} // namespace

// =================================================================================================
// Start, rows and blend
// =================================================================================================

// At a contact start: the proxy goes to the HIP's projection on the triangles around the snapped
// vertex (at_hip), or exactly onto the vertex (modalrt_kernel_contact_begin). A vertex in no
// triangle keeps the snap contact.
void modalrt_kernel::begin_proxy(std::uint32_t hip, bool at_hip) noexcept
{
  Contact            &c = contacts_[hip];
  const std::uint32_t v = c.vertex, first = basis.adjacency.vertex_offsets[v], last = basis.adjacency.vertex_offsets[v + 1];
  if (first == last)
    return;
  double u[3], x[3];
  dot_rows3(c.B, q_.data(), mode_count(), u);
  for (int d = 0; d < 3; ++d) // the HIP relative to the one-ring, which moves with the vertex
    x[d] = (at_hip ? body_inputs_[hip].x[d] : basis.vertices[3 * std::size_t(v) + d] + u[d]) - u[d];
  double best = HUGE_VAL;
  for (std::uint32_t k = first; k < last && best > 0.0; ++k)
    {
      const std::uint32_t  t       = basis.adjacency.vertex_triangles[k];
      const std::uint32_t *corners = &basis.triangles[3 * std::size_t(t)];
      double               w[3], p[3];
      closest_point_weights(x, &basis.vertices[3 * std::size_t(corners[0])], &basis.vertices[3 * std::size_t(corners[1])],
                            &basis.vertices[3 * std::size_t(corners[2])], w);
      for (int d = 0; d < 3; ++d)
        p[d] = w[0] * basis.vertices[3 * std::size_t(corners[0]) + d] + w[1] * basis.vertices[3 * std::size_t(corners[1]) + d] +
               w[2] * basis.vertices[3 * std::size_t(corners[2]) + d] - x[d];
      if (dot3(p, p) < best)
        {
          best             = dot3(p, p);
          c.proxy.triangle = t;
          std::copy_n(w, 3, c.proxy.weights);
        }
    }
  c.proxy.active  = true;
  c.proxy.sliding = false;
  std::fill_n(c.anchor, 3, 0.0);
  compose_proxy(c, true);
  if (!at_hip)
    return;
  // Onto the HIP's projection on the surface as deformed (the one-ring above moved rigidly).
  double p[3], n[3], g[3];
  proxy_point(c, p, n);
  for (int d = 0; d < 3; ++d)
    g[d] = x[d] + u[d] - p[d];
  const double normal_part = dot3(g, n);
  for (int d = 0; d < 3; ++d)
    g[d] -= normal_part * n[d];
  if (walk_proxy(c, g))
    compose_proxy(c, false);
}

// The cached row of `vertex`, loaded (with u = B q) into a slot whose vertex is not one of
// `corners` (the triangle being entered) when absent.
ProxyRow &modalrt_kernel::proxy_row(Contact &c, std::uint32_t vertex, const std::uint32_t *corners) noexcept
{
  ProxyRow *free_slot = nullptr;
  for (ProxyRow &row : c.proxy.rows)
    {
      if (row.vertex == vertex)
        return row;
      if (!free_slot && row.vertex != corners[0] && row.vertex != corners[1] && row.vertex != corners[2])
        free_slot = &row;
    }
  ProxyRow &row = free_slot ? *free_slot : c.proxy.rows[0];
  row.vertex    = vertex;
  row.candidate = load_vertex_row(vertex, row.B);
  dot_rows3(row.B, q_.data(), mode_count(), row.u);
  return row;
}

// The contact's load point from its proxy: rest position, normal and row B blended by the weights;
// its vertex (outputs, region, snapshot) is the heaviest corner. `reload`: the rows are rebuilt
// (a new contact, or a new active space).
void modalrt_kernel::compose_proxy(Contact &c, bool reload) noexcept
{
  ProxyState &proxy = c.proxy;
  if (reload || proxy.rows_space != space_)
    {
      for (ProxyRow &row : proxy.rows)
        row.vertex = MODALRT_NONE;
      proxy.rows_space = space_;
    }
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.triangle)];
  const ProxyRow      *rows[3];
  for (int k = 0; k < 3; ++k)
    rows[k] = &proxy_row(c, corners[k], corners);
  const std::size_t n = 3 * std::size_t(mode_count());
  const double      w0 = proxy.weights[0], w1 = proxy.weights[1], w2 = proxy.weights[2];
  for (std::size_t i = 0; i < n; ++i)
    c.B[i] = w0 * rows[0]->B[i] + w1 * rows[1]->B[i] + w2 * rows[2]->B[i];
  int heaviest = 0;
  for (int k = 1; k < 3; ++k)
    if (proxy.weights[k] > proxy.weights[heaviest])
      heaviest = k;
  double normal[3] = {0.0, 0.0, 0.0};
  for (int d = 0; d < 3; ++d)
    {
      c.rest[d] = 0.0;
      for (int k = 0; k < 3; ++k)
        {
          c.rest[d] += proxy.weights[k] * basis.vertices[3 * std::size_t(corners[k]) + d];
          normal[d] += proxy.weights[k] * basis.normals[3 * std::size_t(corners[k]) + d];
        }
    }
  const double length = norm3(normal);
  for (int d = 0; d < 3; ++d)
    c.normal[d] = length > 0.0 ? normal[d] / length : 0.0;
  c.vertex          = corners[heaviest];
  c.candidate       = rows[heaviest]->candidate;
  contacts_changed_ = true; // the residual compliances and the coupling follow the load point
}

// Where the proxy is on the deformed surface (its contact's correction included) and, unless
// `normal` is null, the blended outward normal there (rest normals: smooth across edges).
void modalrt_kernel::proxy_point(const Contact &c, double point[3], double normal[3]) const noexcept
{
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(c.proxy.triangle)];
  for (int d = 0; d < 3; ++d)
    point[d] = c.correction[d];
  for (int k = 0; k < 3; ++k)
    {
      const ProxyRow &row = row_of(c.proxy, corners[k]);
      const double    w   = c.proxy.weights[k];
      for (int d = 0; d < 3; ++d)
        point[d] += w * (basis.vertices[3 * std::size_t(corners[k]) + d] + row.u[d]);
    }
  if (!normal)
    return;
  for (int d = 0; d < 3; ++d)
    {
      normal[d] = 0.0;
      for (int k = 0; k < 3; ++k)
        normal[d] += c.proxy.weights[k] * basis.normals[3 * std::size_t(corners[k]) + d];
    }
  const double length = norm3(normal);
  for (int d = 0; d < 3; ++d)
    normal[d] = length > 0.0 ? normal[d] / length : 0.0;
}

// =================================================================================================
// The slide (impedance ticks, before the step)
// =================================================================================================
void modalrt_kernel::slide_proxies(std::uint32_t count) noexcept
{
  for (std::uint32_t h = 0; h < count; ++h)
    if (contacts_[h].in_contact && contacts_[h].proxy.active)
      slide_proxy(contacts_[h], body_inputs_[h]);
}

// Coulomb friction on the coupling force a stuck proxy would give, F = K g + D (v_hip - v_surface)
// (g = x_hip - proxy, the surface as the last tick left it), split along the normal of the triangle
// the proxy walks in (at rest, as every normal of the contact) (F_n = -F.n > 0 presses) and across it (F_t). The face's normal, not
// the blended vertex normal: near a sharp edge (a rib's top, 1.8 mm wide) the blended normal tilts
// towards the side face, and its tangential part of a straight press walked the proxy over the edge
// and down the side. The proxy sticks while |F_t| <= mu F_n (mu_s when stuck,
// mu_d when sliding); else it slides along F_t until |F_t| = mu_d F_n (a few passes follow the
// surface's curvature).
void modalrt_kernel::slide_proxy(Contact &c, const BodyInput &in) noexcept
{
  const std::uint32_t r = mode_count();
  for (ProxyRow &row : c.proxy.rows)
    if (row.vertex != MODALRT_NONE)
      dot_rows3(row.B, q_.data(), r, row.u);
  const std::uint32_t region_before = basis.region[c.vertex];
  const double        K = def.coupling_stiffness, D = def.coupling_damping;
  double              relative_velocity[3];
  dot_rows3(c.B, v_.data(), r, relative_velocity);
  for (int d = 0; d < 3; ++d)
    relative_velocity[d] = in.v[d] - relative_velocity[d];
  bool moved = false;
  for (int pass = 0; pass < proxy_passes; ++pass)
    {
      double p[3], n[3], F[3];
      proxy_point(c, p, nullptr);
      face_normal(c, n);
      for (int d = 0; d < 3; ++d)
        F[d] = K * (in.x[d] - p[d]) + D * relative_velocity[d];
      const double normal = -dot3(F, n);
      for (int d = 0; d < 3; ++d)
        F[d] += normal * n[d];
      const double across = norm3(F);
      if (pass == 0)
        {
          const double mu = c.proxy.sliding ? def.dynamic_friction : def.static_friction;
          c.proxy.sliding = normal > 0.0 && K > 0.0 && across > mu * normal;
          if (!c.proxy.sliding)
            break;
        }
      const double excess = across - def.dynamic_friction * std::max(0.0, normal);
      if (excess <= 1e-12 * across)
        break;
      for (int d = 0; d < 3; ++d) // K times this step takes the excess off F_t
        F[d] *= excess / (K * across);
      if (!walk_proxy(c, F))
        break;
      moved = true;
    }
  if (moved)
    compose_proxy(c, false);
  if (basis.region[c.vertex] != region_before)
    proxy_region_changed_ = true;
}

// The outward unit normal of the proxy's triangle at rest (the normals the contact uses are the rest
// ones): its edges' cross product, on the side of its first corner's vertex normal (the display
// surface's winding need not be outward). A degenerate triangle gives that vertex normal.
void modalrt_kernel::face_normal(const Contact &c, double n[3]) const noexcept
{
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(c.proxy.triangle)];
  const double        *a = &basis.vertices[3 * std::size_t(corners[0])], *b = &basis.vertices[3 * std::size_t(corners[1])],
               *e = &basis.vertices[3 * std::size_t(corners[2])], *outward = &basis.normals[3 * std::size_t(corners[0])];
  double e1[3], e2[3];
  for (int d = 0; d < 3; ++d)
    e1[d] = b[d] - a[d], e2[d] = e[d] - a[d];
  double       face[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double length  = norm3(face);
  const double sign    = dot3(face, outward) < 0.0 ? -1.0 : 1.0;
  for (int d = 0; d < 3; ++d)
    n[d] = length > 0.0 ? sign * face[d] / length : outward[d];
}

// Moves the proxy by `step` (body frame, tangential) over the deformed surface: within a triangle
// by its barycentric weights, across an edge into the neighbouring triangle with what is left of
// the step, at most proxy_edge_budget edges; it stops at a boundary edge. True if it moved.
bool modalrt_kernel::walk_proxy(Contact &c, const double step[3]) noexcept
{
  ProxyState &proxy = c.proxy;
  double      remaining[3] = {step[0], step[1], step[2]};
  bool        moved        = false;
  for (std::uint32_t crossing = 0; crossing <= proxy_edge_budget; ++crossing)
    {
      double Y[3][3], dw[3];
      deformed_corners(basis, proxy, Y);
      if (!barycentric_step(Y, remaining, dw))
        break;
      int          exit;
      const double s = advance(proxy.weights, dw, exit);
      moved          = moved || s > 0.0;
      if (exit < 0)
        break;
      const std::uint32_t next = basis.adjacency.neighbour(proxy.triangle, exit);
      if (next == MODALRT_NONE)
        break;
      for (double &r : remaining)
        r *= 1.0 - s;
      const std::uint32_t *from = &basis.triangles[3 * std::size_t(proxy.triangle)];
      const std::uint32_t *to   = &basis.triangles[3 * std::size_t(next)];
      double               w[3] = {0.0, 0.0, 0.0};
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          if (to[j] == from[k])
            w[j] = proxy.weights[k];
      proxy.triangle = next;
      std::copy_n(w, 3, proxy.weights);
      for (int j = 0; j < 3; ++j)
        proxy_row(c, to[j], to);
      moved = true;
    }
  return moved;
}

// =================================================================================================
// Residual compliances, outputs, the passivity observer
// =================================================================================================

void modalrt::blended_residual(const ModalSpace &space, const LoadCorner *a, int na, const LoadCorner *b, int nb,
                               bool same, double C[9])
{
  std::fill_n(C, 9, 0.0);
  for (int i = 0; i < na; ++i)
    for (int j = 0; j < nb; ++j)
      {
        const int    ci = a[i].candidate, cj = b[j].candidate;
        const double w  = a[i].weight * b[j].weight;
        if (ci < 0 || cj < 0 || w == 0.0)
          continue;
        double block[9];
        if (space.cross_count > 0)
          {
            if (space.residual_compliance(std::uint32_t(ci), std::uint32_t(cj), block))
              for (int k = 0; k < 9; ++k)
                C[k] += w * block[k];
          }
        else if (same && i == j)
          for (int k = 0; k < 9; ++k)
            C[k] += a[i].weight * space.candidate_compliance[9 * std::size_t(ci) + k];
      }
}

// C_ab between two contacts, at least one a proxy (blended_residual of their loads).
void modalrt_kernel::proxy_pair_compliance(const Contact &a, const Contact &b, double C[9]) const noexcept
{
  std::fill_n(C, 9, 0.0);
  if (!def.use_static_correction)
    return;
  auto load_corners = [this](const Contact &c, LoadCorner corners[3]) {
    if (!c.proxy.active)
      {
        corners[0] = {c.candidate, 1.0};
        return 1;
      }
    const std::uint32_t *vertices = &basis.triangles[3 * std::size_t(c.proxy.triangle)];
    for (int k = 0; k < 3; ++k)
      corners[k] = {row_of(c.proxy, vertices[k]).candidate, c.proxy.weights[k]};
    return 3;
  };
  LoadCorner pa[3], pb[3];
  const int  na = load_corners(a, pa), nb = load_corners(b, pb);
  blended_residual(basis.spaces[space_], pa, na, pb, nb, &a == &b, C);
}

void modalrt_kernel::write_proxy_output(const Contact &c, modalrt_hip_output &out) const noexcept
{
  if (!c.proxy.active)
    return;
  out.proxy_triangle = c.proxy.triangle;
  std::copy_n(c.proxy.weights, 3, out.proxy_weights);
  if (c.proxy.sliding)
    out.flags |= MODALRT_HIP_SLIDING;
}

// The work the hand did on the kernel over the last period: the force commanded then (held by the
// device) times how far the HIP moved, -F . dx, summed over HIPs. Admittance ticks (null inputs)
// are not observed.
void modalrt_kernel::observe_passivity(const modalrt_hip_input *inputs, std::uint32_t count) noexcept
{
  if (!inputs)
    {
      observed_count_ = 0;
      return;
    }
  for (std::uint32_t h = 0; h < count; ++h)
    {
      double *x = &observed_positions_[3 * std::size_t(h)];
      if (h < observed_count_)
        for (int d = 0; d < 3; ++d)
          stats.passivity_energy -= last_outputs_[h].force[d] * (inputs[h].position[d] - x[d]);
      std::copy_n(inputs[h].position, 3, x);
    }
  observed_count_ = count;
}
