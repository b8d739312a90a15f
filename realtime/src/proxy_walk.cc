// The walk of a sliding contact's proxy (proxy_walk.h).
//
// On an edge or a vertex (weights exactly 0, as a walk leaves them) a step that leaves the triangle
// at once is resolved so that the walk makes progress instead of handing the proxy back and forth
// (a slide along a row of mesh edges stalled so: 15 crossings a tick, handed between the two
// triangles of an edge, until released):
// - across a boundary edge or into a crease (creased; or the edge this walk just came in through,
//   whose triangle pointed the step here): the step's part along the edge, the proxy stays on the
//   edge (the line both faces lead to) until it reaches a vertex;
// - at a vertex, leaving through both edges: never back through the edge it came in through, else
//   away from the corner the step turns from most (the smaller cosine with its edge), so that the
//   walk goes round the vertex's fan one way until the triangle that holds the step.
#include "proxy_walk.h"

#include "dense.h"
#include "triangle_geometry.h"
#include "vector3.h"

#include <algorithm>

using namespace modalrt;

void modalrt::deform_triangle(const modalrt_basis &basis, ProxyState &proxy, std::uint64_t state) noexcept
{
  DeformedTriangle &t = proxy.deformed;
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.triangle)];
  for (int k = 0; k < 3; ++k)
    for (int d = 0; d < 3; ++d)
      t.Y[k][d] = basis.vertices[3 * std::size_t(corners[k]) + d] + proxy.corner(k).u[d];
  t.system   = triangle_system(t.Y);
  t.triangle = proxy.triangle;
  t.state    = state;
}

// The outward unit normal of display triangle `triangle` at rest: its edges' cross product, on the
// side of its first corner's vertex normal (the display surface's winding need not be outward). A
// degenerate triangle gives that vertex normal.
void modalrt::face_normal(const modalrt_basis &basis, std::uint32_t triangle, double n[3]) noexcept
{
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(triangle)];
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

namespace
{
  // Whether the proxy, on the edge of its triangle opposite `corner`, cannot cross it with `step`: a
  // boundary edge, or a crease, where the neighbour across it, as deformed, has the step point back
  // across the edge (its corner off the edge would lose weight): each face hands the step to the
  // other, and a walk that crossed would come straight back. A crease is not reported where that is
  // not known without building a row (the neighbour's corner row not ready in a slot): the walk then
  // crosses, and its entry rule catches it.
  bool creased(ProxyState &proxy, int corner, const double step[3], const ProxyRowView &view) noexcept
  {
    const modalrt_basis &basis = view.basis;
    const std::uint32_t  next  = basis.adjacency.neighbour(proxy.triangle, corner);
    if (next == MODALRT_NONE)
      return true;
    const std::uint32_t *from = &basis.triangles[3 * std::size_t(proxy.triangle)];
    const std::uint32_t *to   = &basis.triangles[3 * std::size_t(next)];
    double               Y[3][3], dw[3];
    int                  off = -1;
    for (int j = 0; j < 3; ++j)
      {
        const double *u = nullptr;
        for (int k = 0; k < 3; ++k)
          if (to[j] == from[k])
            u = proxy.corner(k).u;
        if (!u)
          {
            const int slot = find_slot(proxy, to[j]);
            if (slot < 0 || !proxy.rows[slot].ready)
              return false;
            ProxyRow &row = proxy.rows[slot];
            if (row.u_stamp != view.state_stamp)
              dot_rows3(row.B, view.q, view.mode_count(), row.u), row.u_stamp = view.state_stamp;
            u = row.u, off = j;
          }
        for (int d = 0; d < 3; ++d)
          Y[j][d] = basis.vertices[3 * std::size_t(to[j]) + d] + u[d];
      }
    return off >= 0 && barycentric_step(triangle_system(Y), step, dw) && dw[off] < 0.0;
  }

  // At vertex v of triangle Y, leaving through both corners `leaving` (at 0 weight, the step would
  // make both negative): the corner to leave across from.
  int exit_at_vertex(const DeformedTriangle &Y, const double remaining[3], const int leaving[2], int entry) noexcept
  {
    const int v    = 3 - leaving[0] - leaving[1];
    auto      turn = [&](int k) {
      double e[3];
      for (int d = 0; d < 3; ++d)
        e[d] = Y.Y[k][d] - Y.Y[v][d];
      return dot3(remaining, e) / norm3(e);
    };
    return leaving[0] == entry ? leaving[1]
           : leaving[1] == entry ? leaving[0]
           : turn(leaving[0]) <= turn(leaving[1]) ? leaving[0] : leaving[1];
  }

  // Along the edge opposite corner k (its ends a, b; the corner off it stays at 0) with the step's
  // part along it. False when the walk ends here: at a vertex the edge leads away from, or with the
  // whole step taken; else the proxy is at the vertex and `remaining` what is left of the step.
  bool along_edge(ProxyState &proxy, const DeformedTriangle &Y, int k, double remaining[3], bool &moved) noexcept
  {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    double    e[3], dw[3];
    for (int d = 0; d < 3; ++d)
      e[d] = Y.Y[b][d] - Y.Y[a][d];
    const double t = dot3(remaining, e) / dot3(e, e);
    dw[k] = 0.0, dw[a] = -t, dw[b] = t;
    if ((proxy.weights[a] == 0.0 && t > 0.0) || (proxy.weights[b] == 0.0 && t < 0.0))
      return false; // at a vertex, the edge leads away: nowhere to go from here this time
    int          end;
    const double s = advance(proxy.weights, dw, end);
    moved          = moved || s > 0.0;
    if (end < 0)
      return false;
    for (int d = 0; d < 3; ++d) // at the vertex: the next pass of the walk leaves it
      remaining[d] *= 1.0 - s;
    return true;
  }

  // The proxy crosses into triangle `next`, its weights carried over the shared corners; the new
  // corner's row comes from the look-ahead (or is built now), and `entry` becomes that corner.
  void enter_triangle(ProxyState &proxy, std::uint32_t next, int &entry, const ProxyRowView &view) noexcept
  {
    const std::uint32_t *from = &view.basis.triangles[3 * std::size_t(proxy.triangle)];
    const std::uint32_t *to   = &view.basis.triangles[3 * std::size_t(next)];
    double               w[3] = {0.0, 0.0, 0.0};
    int                  slot[3] = {-1, -1, -1};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        if (to[j] == from[k])
          w[j] = proxy.weights[k], slot[j] = proxy.corner_slot[k];
    ++proxy.crossings;
    proxy.packed_triangle = MODALRT_NONE;
    for (int j = 0; j < 3; ++j)
      if (slot[j] < 0)
        slot[j] = corner_row(proxy, to[j], to, view), entry = j;
    for (int j = 0; j < 3; ++j)
      proxy.corner_slot[j] = std::uint8_t(slot[j]), proxy.rows[slot[j]].stamp = proxy.crossings;
    proxy.triangle = next;
    std::copy_n(w, 3, proxy.weights);
  }
} // namespace

bool modalrt::walk_proxy(ProxyState &proxy, const double step[3], const ProxyRowView &view) noexcept
{
  double remaining[3] = {step[0], step[1], step[2]};
  bool   moved        = false;
  int    entry        = -1; // the corner opposite the edge this walk entered the triangle through
  for (std::uint32_t crossing = 0; crossing <= proxy_edge_budget; ++crossing)
    {
      const DeformedTriangle &Y = deformed_triangle(view.basis, proxy, view.state_stamp);
      double                  dw[3];
      if (!barycentric_step(Y.system, remaining, dw))
        break;
      int leaving[2], count = 0; // corners at 0 that the step would make negative
      for (int k = 0; k < 3; ++k)
        if (proxy.weights[k] == 0.0 && dw[k] < 0.0)
          leaving[count++] = k;
      int exit = -1;
      if (count == 2) // at a vertex
        exit = exit_at_vertex(Y, remaining, leaving, entry);
      else if (count == 1 && (leaving[0] == entry || creased(proxy, leaving[0], remaining, view)))
        {
          if (!along_edge(proxy, Y, leaving[0], remaining, moved))
            break;
          continue;
        }
      else if (count == 1)
        exit = leaving[0];
      double s = 0.0;
      if (exit < 0)
        {
          s     = advance(proxy.weights, dw, exit);
          moved = moved || s > 0.0;
          if (exit < 0)
            break;
        }
      const std::uint32_t next = view.basis.adjacency.neighbour(proxy.triangle, exit);
      if (next == MODALRT_NONE)
        break;
      for (double &r : remaining)
        r *= 1.0 - s;
      enter_triangle(proxy, next, entry, view);
      moved = true;
    }
  return moved;
}
