// The sliding contact (contact_mode = MODALRT_CONTACT_PROXY): a proxy on the deformed display
// surface that the HIP is coupled to (god-object), moved by Coulomb friction before each impedance
// step. Its load point is its position on its triangle: the barycentric blend of the corners' rows,
// rest positions, normals and residual compliances, so the force and the felt compliance stay
// continuous as it crosses from one vertex's neighbourhood to the next. modalrt.h states the rules;
// the passivity observer of the impedance ticks is here too.
//
// The tick's cost (realtime/README.md): the rows of the vertices the proxy is about to reach, and the
// pair blocks B_k G B_l^T of their triangles, are prepared ahead a bounded amount per tick
// (prepare_proxy), so that a crossing finds them ready; the coupling block then needs no pass over
// the modes (proxy_coupling_block), and the corners' displacements B_k q come from the last tick's
// outputs (proxy_displacement).
#include "kernel.h"

#include "dense.h"
#include "proxy_rows.h"
#include "proxy_walk.h"
#include "triangle_geometry.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

using namespace modalrt;

namespace
{
  // The inverse of a 3 x 3 row-major matrix by its cofactors; false (inverse untouched) when it is
  // singular or not finite.
  bool invert3(const double A[9], double inverse[9])
  {
    const double c[9] = {A[4] * A[8] - A[5] * A[7], A[2] * A[7] - A[1] * A[8], A[1] * A[5] - A[2] * A[4],
                         A[5] * A[6] - A[3] * A[8], A[0] * A[8] - A[2] * A[6], A[2] * A[3] - A[0] * A[5],
                         A[3] * A[7] - A[4] * A[6], A[1] * A[6] - A[0] * A[7], A[0] * A[4] - A[1] * A[3]};
    const double det = A[0] * c[0] + A[1] * c[3] + A[2] * c[6];
    if (!(std::fabs(det) > 1e-300) || !std::isfinite(det))
      return false;
    for (int e = 0; e < 9; ++e)
      inverse[e] = c[e] / det;
    return true;
  }

  void multiply3(const double M[9], const double x[3], double out[3])
  {
    for (int i = 0; i < 3; ++i)
      out[i] = M[3 * i] * x[0] + M[3 * i + 1] * x[1] + M[3 * i + 2] * x[2];
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
  if (walk_proxy(c.proxy, g, row_view()))
    compose_proxy(c, false);
}

// The contact's load point from its proxy: rest position, normal and row B blended by the weights;
// its vertex (outputs, region, snapshot) is the heaviest corner. `reload`: the rows are rebuilt
// (a new contact, or a new active space).
void modalrt_kernel::compose_proxy(Contact &c, bool reload) noexcept
{
  ProxyState          &proxy   = c.proxy;
  const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.triangle)];
  if (reload || proxy.rows_space != space_)
    {
      for (ProxyRow &row : proxy.rows)
        row.clear();
      proxy.rows_space      = space_;
      proxy.ahead_triangle  = MODALRT_NONE;
      proxy.packed_triangle = MODALRT_NONE;
      ++proxy.crossings;
      for (int k = 0; k < 3; ++k)
        proxy.corner_slot[k] = corner_row(proxy, corners[k], corners, row_view());
    }
  const ProxyRow *rows[3] = {&proxy.corner(0), &proxy.corner(1), &proxy.corner(2)};
  const std::size_t n = 3 * std::size_t(mode_count());
  const double      w0 = proxy.weights[0], w1 = proxy.weights[1], w2 = proxy.weights[2];
  // Local pointers: the rows cannot alias the contact's blended row (another buffer, or the basis),
  // which the compiler could not know through c.B and vectorizes with them.
  const double *const b0 = rows[0]->B, *const b1 = rows[1]->B, *const b2 = rows[2]->B;
  double *const       B  = c.B;
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i)
    B[i] = w0 * b0[i] + w1 * b1[i] + w2 * b2[i];
  int heaviest = 0;
  for (int k = 1; k < 3; ++k)
    if (proxy.weights[k] > proxy.weights[heaviest])
      heaviest = k;
  double normal[3] = {0.0, 0.0, 0.0};
  for (int d = 0; d < 3; ++d)
    {
      double rest = 0.0;
      for (int k = 0; k < 3; ++k)
        {
          rest += proxy.weights[k] * basis.vertices[3 * std::size_t(corners[k]) + d];
          normal[d] += proxy.weights[k] * basis.normals[3 * std::size_t(corners[k]) + d];
        }
      c.rest[d] = rest;
    }
  const double length = norm3(normal), scale = length > 0.0 ? 1.0 / length : 0.0;
  for (int d = 0; d < 3; ++d)
    c.normal[d] = normal[d] * scale;
  c.vertex          = corners[heaviest];
  c.candidate       = rows[heaviest]->candidate;
  pack_triangle(proxy, row_view(), def.use_static_correction != 0);
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
      const ProxyRow &row = c.proxy.corner(k);
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
  // The free step (no contact force) of this tick, which slide_proxy's force starts from; the
  // impedance step makes it again (in the space a switch may pick after the slide).
  bool stepped = false;
  // The other contacts' share of each load point's motion over the tick, sum_b (B_a G B_b^T + C_ab)
  // F_b and sum_b B_a H B_b^T F_b with their last forces, from the last step's coupling blocks while
  // the set of contacts is the one they were made for.
  const bool          blocks = !contacts_changed_ && !coupling_dirty_;
  const std::uint32_t n3     = 3 * active_count_;
  for (std::uint32_t h = 0; h < count; ++h)
    if (contacts_[h].in_contact && contacts_[h].proxy.active)
      {
        if (!stepped)
          {
            frame_modal_force(f_.data());
            integrators_[space_].step_to(q_.data(), v_.data(), f_.data(), q_free_.data(), v_free_.data());
            stepped = true;
          }
        double         others_u[3] = {0.0, 0.0, 0.0}, others_v[3] = {0.0, 0.0, 0.0};
        std::uint32_t  a = 0;
        while (blocks && a < active_count_ && active_[a] != h)
          ++a;
        for (std::uint32_t b = 0; blocks && a < active_count_ && b < active_count_; ++b)
          if (b != a)
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j)
                {
                  const double      F  = contacts_[active_[b]].force[j];
                  const std::size_t ab = (3 * a + i) * n3 + 3 * b + j;
                  others_u[i] += coupling_[ab] * F, others_v[i] += coupling_velocity_[ab] * F;
                }
        slide_proxy(contacts_[h], body_inputs_[h], others_u, others_v);
      }
}

// Coulomb friction on the force the step will give with the proxy stuck where it is, split along the
// normal of the triangle the proxy walks in (at rest, as every normal of the contact) (F_n = -F.n > 0
// presses) and across it (F_t). The face's normal, not the blended vertex normal: near a sharp edge
// (a rib's top, 1.8 mm wide) the blended normal tilts towards the side face, and its tangential part
// of a straight press walked the proxy over the edge and down the side. The proxy sticks while
// |F_t| <= mu F_n (mu_s when stuck, mu_d when sliding); else it slides along the surface until
// |F_t| = mu_d F_n, to proxy_friction_tolerance (a few passes follow the surface's curvature). No
// pressing force, no friction: a proxy whose force does not press slides to F_t = 0.
//
// The force is the coupling's as impedance_step solves it with the modal step, for this contact
// held: F = A^-1 (K (x_hip - rest - B q_f - u_o) + D (v_hip - B v_f - v_o)), A = I + K S + D Sv,
// (q_f, v_f) the free step, S = B G B^T + C the contact's own block, Sv = B H B^T its velocity's,
// u_o and v_o the other contacts' share of the point's motion (slide_proxies). The explicit force
// K (x_hip - p) + D (v_hip - v_p) of the surface as the last tick left it (p) is what the test took
// before: with a soft coupling (no haptic scale, K S ~ 0.01) the two differ by about K S, but with a
// haptic scale the coupling on the part is 200 times the band's top (K S >> 1) and the explicit
// force is K times a gap of a fraction of a micrometre. The surface moving by that much in a tick
// flipped its sign while the step's force, set by the part's own compliance, still pressed; the
// proxy stuck at such ticks while the hand moved on, the step's force dragged the part sideways (a
// rib along its length, as stiff as a wall), and the hand felt F_t up to 20 times F_n (the default
// scene's slide on omega.x). Moving the proxy by delta changes F by -A^-1 K delta, so the walk's
// step that takes an excess e off F_t is K^-1 A e (in the face's plane).
void modalrt_kernel::slide_proxy(Contact &c, const BodyInput &in, const double others_u[3], const double others_v[3]) noexcept
{
  // The corners' displacements as write_outputs left them, unless the state moved since.
  ProxyState         &proxy = c.proxy;
  const std::uint32_t r     = mode_count();
  for (int k = 0; k < 3; ++k)
    if (proxy.corner(k).u_stamp != state_stamp_)
      dot_rows3(proxy.corner(k).B, q_.data(), r, proxy.corner(k).u), proxy.corner(k).u_stamp = state_stamp_;
  const std::uint32_t region_before = basis.region[c.vertex], crossings_before = proxy.crossings;
  const double        K = def.coupling_stiffness, D = def.coupling_damping;
  // The free step's displacement of the load point beyond the last tick's (B (q_f - q)) and the other
  // contacts' share, which the walk carries to the points it moves to (a few micrometres a tick),
  // and the velocity's.
  double free_u[3], free_v[3], relative_velocity[3];
  dot_rows3_pair(c.B, q_free_.data(), v_free_.data(), r, free_u, free_v);
  for (int d = 0; d < 3; ++d)
    {
      free_u[d] += others_u[d] - (proxy.weights[0] * proxy.corner(0).u[d] + proxy.weights[1] * proxy.corner(1).u[d] +
                                  proxy.weights[2] * proxy.corner(2).u[d]);
      relative_velocity[d] = in.v[d] - free_v[d] - others_v[d];
    }
  // A and A^-1 at the proxy's weights (kept over the walk's micrometres); a singular A leaves the explicit force.
  double S[9], Sv[9], C[9], A[9], A_inverse[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  proxy_coupling_block(proxy, S, Sv);
  proxy_pair_compliance(c, c, C);
  for (int e = 0; e < 9; ++e)
    A[e] = (e % 4 == 0 ? 1.0 : 0.0) + K * (S[e] + C[e]) + D * Sv[e];
  if (!invert3(A, A_inverse))
    for (int e = 0; e < 9; ++e)
      A[e] = e % 4 == 0 ? 1.0 : 0.0, A_inverse[e] = A[e];
  bool moved = false;
  for (int pass = 0; pass < proxy_passes; ++pass)
    {
      double                  p[3], n[3], F_e[3], F[3];
      const DeformedTriangle &Y = deformed_triangle(basis, proxy, state_stamp_);
      for (int d = 0; d < 3; ++d) // proxy_point's sum, over the corners as deformed
        p[d] = c.correction[d] + proxy.weights[0] * Y.Y[0][d] + proxy.weights[1] * Y.Y[1][d] + proxy.weights[2] * Y.Y[2][d];
      std::copy_n(proxy_face_normal(basis, proxy), 3, n);
      for (int d = 0; d < 3; ++d) // p less the last tick's correction C F_last: A holds C F
        F_e[d] = K * (in.x[d] - p[d] + c.correction[d] - free_u[d]) + D * relative_velocity[d];
      multiply3(A_inverse, F_e, F);
      const double normal = -dot3(F, n);
      for (int d = 0; d < 3; ++d)
        F[d] += normal * n[d];
      const double across = norm3(F);
      if (pass == 0)
        {
          const double mu = c.proxy.sliding ? def.dynamic_friction : def.static_friction;
          c.proxy.sliding = K > 0.0 && across > mu * std::max(0.0, normal);
          if (!c.proxy.sliding)
            break;
        }
      const double excess = across - def.dynamic_friction * std::max(0.0, normal);
      if (excess <= proxy_friction_tolerance * across)
        break;
      double step[3];
      multiply3(A, F, step);
      const double off_face = dot3(step, n);
      for (int d = 0; d < 3; ++d) // -A^-1 K times this step takes the excess off F_t
        step[d] = (step[d] - off_face * n[d]) * excess / (K * across);
      if (!walk_proxy(proxy, step, row_view()))
        break;
      if (pass == 0)
        std::copy_n(step, 3, c.proxy.heading); // where the look-ahead expects the proxy to go
      moved = true;
    }
  if (moved)
    compose_proxy(c, false);
  if (basis.region[c.vertex] != region_before)
    proxy_region_changed_ = true;
  // The tick that entered a triangle has done the crossing's own work: the look-ahead of the new
  // triangle waits for the next tick (up to proxy_lookahead_deferrals such ticks in a row: a proxy
  // crossing at every tick still gets it).
  const bool entered  = proxy.crossings != crossings_before;
  if (entered && proxy.lookahead_deferrals < proxy_lookahead_deferrals)
    ++proxy.lookahead_deferrals;
  else
    proxy.lookahead_deferrals = 0, prepare_proxy(proxy, row_view());
}

// Coulomb's bound on the force the step solved (impedance_step, before the force limit and the
// validity clamp, which scale the whole force and so keep it): |F_t| <= mu F_n about the face's
// normal, mu that of the proxy's state (mu_s stuck, mu_d sliding). slide_proxy decided on this
// force's estimate, which leaves out the other contacts' share of the point's motion and the
// surface's free motion beyond its velocity; where that leaves the solved force outside the cone,
// the contact slips by the difference this tick (its tangential part is brought back to the cone's
// edge, the part and the hand get the same force) and the next tick's slide moves the proxy. A
// force that does not press is left to the release rule.
void modalrt_kernel::hold_in_friction_cone(Contact &c, double F[3]) noexcept
{
  const double *n = proxy_face_normal(basis, c.proxy), normal = -dot3(F, n);
  if (!(normal > 0.0))
    return;
  double t[3];
  for (int d = 0; d < 3; ++d)
    t[d] = F[d] + normal * n[d];
  const double across = norm3(t), limit = (c.proxy.sliding ? def.dynamic_friction : def.static_friction) * normal;
  if (!(across > limit))
    return;
  for (int d = 0; d < 3; ++d)
    F[d] = -normal * n[d] + t[d] * (limit / across);
}

// =================================================================================================
// Residual compliances, outputs, the passivity observer
// =================================================================================================

bool modalrt::blended_residual(const ModalSpace &space, const LoadCorner *a, int na, const LoadCorner *b, int nb,
                               bool same, double C[9])
{
  std::fill_n(C, 9, 0.0);
  bool exact = true;
  for (int i = 0; i < na; ++i)
    for (int j = 0; j < nb; ++j)
      {
        const int    ci = a[i].candidate, cj = b[j].candidate;
        const double w  = a[i].weight * b[j].weight;
        if (ci < 0 || cj < 0 || w == 0.0)
          continue;
        double block[9];
        if (space.couples_distinct_candidates())
          {
            const ModalSpace::Coupling coupling = space.residual_coupling(std::uint32_t(ci), std::uint32_t(cj), block);
            exact = exact && coupling == ModalSpace::Coupling::exact;
            if (coupling != ModalSpace::Coupling::none)
              for (int k = 0; k < 9; ++k)
                C[k] += w * block[k];
          }
        else if (same && i == j)
          for (int k = 0; k < 9; ++k)
            C[k] += a[i].weight * space.candidate_compliance[9 * std::size_t(ci) + k];
        else
          exact = false;
      }
  return exact;
}

// C_ab between two contacts, at least one a proxy (blended_residual of their loads).
void modalrt_kernel::proxy_pair_compliance(const Contact &a, const Contact &b, double C[9]) const noexcept
{
  std::fill_n(C, 9, 0.0);
  if (!def.use_static_correction)
    return;
  if (&a == &b && a.proxy.packed_triangle == a.proxy.triangle)
    {
      if (!a.proxy.residual_any)
        return;
      // blended_residual's sum over the pairs of its triangle's corners, from the blocks packed once
      // per triangle (pack_triangle): 54 multiply-adds, no branch.
      const double *w       = a.proxy.weights;
      const double  c[6]    = {a.proxy.residual_linear ? w[0] : w[0] * w[0], a.proxy.residual_linear ? w[1] : w[1] * w[1],
                               a.proxy.residual_linear ? w[2] : w[2] * w[2], w[0] * w[1], w[0] * w[2], w[1] * w[2]};
      const double(&R)[6][9] = a.proxy.residual;
#pragma omp simd
      for (int e = 0; e < 9; ++e)
        C[e] = c[0] * R[0][e] + c[1] * R[1][e] + c[2] * R[2][e] + c[3] * R[3][e] + c[4] * R[4][e] + c[5] * R[5][e];
      return;
    }
  auto load_corners = [](const Contact &c, LoadCorner corners[3]) {
    if (!c.proxy.active)
      {
        corners[0] = {c.candidate, 1.0};
        return 1;
      }
    for (int k = 0; k < 3; ++k)
      corners[k] = {c.proxy.corner(k).candidate, c.proxy.weights[k]};
    return 3;
  };
  LoadCorner pa[3], pb[3];
  const int  na = load_corners(a, pa), nb = load_corners(b, pb);
  blended_residual(basis.spaces[space_], pa, na, pb, nb, &a == &b, C);
}

// The load point's displacement B q and velocity B v for the outputs, by way of its corners'
// displacements u_k = B_k q (B q = sum_k w_k u_k), which the next tick's slide starts from.
void modalrt_kernel::proxy_displacement(Contact &c, double u[3], double u_dot[3]) noexcept
{
  ProxyState &proxy = c.proxy;
  double      corner_u[9];
  dot_corners_pair(proxy.corner(0).B, proxy.corner(1).B, proxy.corner(2).B, c.B, q_.data(), v_.data(), mode_count(),
                   corner_u, u_dot);
  for (int k = 0; k < 3; ++k)
    std::copy_n(corner_u + 3 * k, 3, proxy.corner(k).u), proxy.corner(k).u_stamp = state_stamp_;
  for (int d = 0; d < 3; ++d)
    u[d] = proxy.weights[0] * corner_u[d] + proxy.weights[1] * corner_u[3 + d] + proxy.weights[2] * corner_u[6 + d];
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
