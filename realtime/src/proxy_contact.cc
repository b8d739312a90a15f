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
#include "vector3.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

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

  // The edges of a triangle Y and their normal equations, for barycentric_step.
  TriangleSystem triangle_system(const double Y[3][3])
  {
    TriangleSystem t;
    for (int d = 0; d < 3; ++d)
      t.e1[d] = Y[1][d] - Y[0][d], t.e2[d] = Y[2][d] - Y[0][d];
    t.a11 = dot3(t.e1, t.e1), t.a12 = dot3(t.e1, t.e2), t.a22 = dot3(t.e2, t.e2), t.det = t.a11 * t.a22 - t.a12 * t.a12;
    t.inverse_det = 1.0 / t.det;
    return t;
  }

  // The proxy's triangle as deformed (corners at rest + u, without the contact's correction, a
  // common offset) and its system, made once per triangle and modal state.
  const DeformedTriangle &deformed_triangle(const modalrt_basis &basis, ProxyState &proxy, std::uint64_t state)
  {
    DeformedTriangle &t = proxy.deformed;
    if (t.triangle == proxy.triangle && t.state == state)
      return t;
    const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.triangle)];
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d)
        t.Y[k][d] = basis.vertices[3 * std::size_t(corners[k]) + d] + proxy.corner(k).u[d];
    t.system   = triangle_system(t.Y);
    t.triangle = proxy.triangle;
    t.state    = state;
    return t;
  }

  // The slot holding `vertex`'s row (ready or not), -1 if none.
  int find_slot(const ProxyState &proxy, std::uint32_t vertex)
  {
    for (std::uint32_t s = 0; s < proxy_row_slots; ++s)
      if (proxy.rows[s].vertex == vertex)
        return int(s);
    return -1;
  }

  // Barycentric change dw (sum 0) whose displacement over the triangle is the projection of `step`
  // on its plane (least squares over the two edges). False for a degenerate triangle.
  bool barycentric_step(const TriangleSystem &t, const double step[3], double dw[3])
  {
    if (!(t.det > 1e-12 * t.a11 * t.a22))
      return false;
    const double b1 = dot3(step, t.e1), b2 = dot3(step, t.e2);
    const double s1 = (t.a22 * b1 - t.a12 * b2) * t.inverse_det, s2 = (t.a11 * b2 - t.a12 * b1) * t.inverse_det;
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
    const double scale = 1.0 / sum;
    for (int k = 0; k < 3; ++k)
      w[k] *= scale;
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

// A slot for `vertex`'s row, taken from a vertex that is not wanted: never a corner of `keep` (the
// triangle the proxy is on or entering); an empty slot first, else the one wanted longest ago (the
// look-ahead's rows carry the current stamp). A stored row (StoredRows) is read in place, ready at
// once; any other patch row starts empty and is accumulated by add_row_entries. The slot's pair
// blocks are void.
int modalrt_kernel::acquire_row(Contact &c, std::uint32_t vertex, const std::uint32_t *keep) noexcept
{
  ProxyState &proxy = c.proxy;
  int         best  = -1;
  for (std::uint32_t s = 0; s < proxy_row_slots; ++s)
    {
      const ProxyRow &row = proxy.rows[s];
      if (row.vertex == MODALRT_NONE)
        {
          best = int(s);
          break;
        }
      if (row.vertex == keep[0] || row.vertex == keep[1] || row.vertex == keep[2])
        continue;
      if (best < 0 || row.stamp < proxy.rows[best].stamp)
        best = int(s);
    }
  ProxyRow         &row   = proxy.rows[best]; // slots outnumber a triangle's corners: never -1
  const ModalSpace &space = basis.spaces[space_];
  row.clear();
  row.vertex    = vertex;
  row.candidate = space.candidate_index(vertex);
  row.stamp     = proxy.crossings;
  if (const double *stored = stored_row(space_, vertex))
    {
      row.B      = stored;
      row.ready  = true;
      row.stored = true;
      // Most rows are taken by the look-ahead: fetched into the cache now, the crossing that reaches
      // them (B q, the blended row) does not wait for memory.
      prefetch(row.B, 3 * sizeof(double) * std::size_t(space.mode_count));
    }
  else
    {
      std::fill_n(row.buffer, 3 * std::size_t(space.mode_count), 0.0);
      row.B = row.buffer;
    }
  for (std::uint32_t s = 0; s < proxy_row_slots; ++s)
    proxy.gram(std::uint32_t(best), s).clear();
  return best;
}

// Accumulates up to `budget` more patch entries into a row that is not ready; returns how many.
std::uint32_t modalrt_kernel::add_row_entries(ProxyRow &row, std::uint32_t budget) const noexcept
{
  const std::uint32_t size = patch_size(basis, row.vertex), end = std::min(size, row.built + budget);
  const std::uint32_t done = end - row.built;
  add_patch_entries(basis, basis.spaces[space_], row.vertex, row.built, end, row.buffer);
  row.built = end;
  row.ready = end == size;
  return done;
}

namespace
{
  // Adds the modes [first, last) of the pair block of rows a and b (a == b: a row's own block) in
  // chunks of proxy_gram_chunk counted from mode 0, so that a block is the same sum whoever makes it.
  void add_gram_chunks(const double *a, const double *b, const double *g1, const double *g2, std::uint32_t r,
                       std::uint32_t first, std::uint32_t last, double M[9], double N[9]) noexcept
  {
    for (std::uint32_t begin = first; begin < last; begin += proxy_gram_chunk)
      {
        const std::uint32_t end = std::min(r, begin + proxy_gram_chunk);
        if (a == b)
          add_own_gram(a, g1, g2, r, begin, end, M, N);
        else
          add_pair_gram(a, b, g1, g2, r, begin, end, M, N);
      }
  }
} // namespace

// The contact row of `vertex` in `space` that the kernel holds (StoredRows), nullptr if none.
const double *modalrt_kernel::stored_row(std::uint32_t space_index, std::uint32_t vertex) const noexcept
{
  const ModalSpace &space = basis.spaces[space_index];
  if (const int c = space.candidate_index(vertex); c >= 0)
    return &space.candidate_modes[3 * std::size_t(space.mode_count) * std::size_t(c)];
  if (space_index >= stored_rows_.size() || stored_rows_[space_index].patch_row_of.empty())
    return nullptr;
  const StoredRows   &stored = stored_rows_[space_index];
  const std::uint32_t k      = stored.patch_row_of[vertex];
  return k == MODALRT_NONE ? nullptr : &stored.patch_rows[3 * std::size_t(space.mode_count) * k];
}

namespace
{
  // The pairs (a, b), a <= b, of display vertices that share a triangle, and each vertex with itself,
  // sorted, whose rows `has_row` says are stored.
  template <typename HasRow>
  std::vector<std::pair<std::uint32_t, std::uint32_t>> triangle_pairs(const modalrt_basis &basis, HasRow has_row)
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
    for (std::uint32_t v = 0; v < basis.vertex_count; ++v)
      if (has_row(v))
        pairs.emplace_back(v, v);
    for (std::uint32_t t = 0; t < basis.triangle_count; ++t)
      for (int k = 0; k < 3; ++k)
        {
          const std::uint32_t a = basis.triangles[3 * std::size_t(t) + k];
          const std::uint32_t b = basis.triangles[3 * std::size_t(t) + (k + 1) % 3];
          if (has_row(a) && has_row(b))
            pairs.emplace_back(std::min(a, b), std::max(a, b));
        }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    return pairs;
  }
} // namespace

// For every space, at creation: the patch rows of its display vertices that are not candidates
// (StoredRows; a space whose rows and pair blocks would take the memory past def.proxy_row_memory
// keeps only its candidates'), then the pair blocks and residual couplings of every two vertices
// with stored rows that share a triangle, and of each with itself (StoredGrams): 24 r multiply-adds
// a pair, once.
void modalrt_kernel::make_stored_rows()
{
  const std::uint32_t nv = basis.vertex_count;
  stored_rows_.resize(basis.space_count());
  stored_grams_.resize(basis.space_count());
  const std::size_t limit = def.proxy_row_memory == MODALRT_PROXY_ROWS_IN_TICKS ? 0
                            : std::size_t(def.proxy_row_memory == 0 ? proxy_default_row_memory_mib : def.proxy_row_memory)
                                  << 20;
  std::size_t memory = 0;
  for (std::uint32_t s = 0; s < basis.space_count(); ++s)
    {
      const ModalSpace      &space      = basis.spaces[s];
      const ModalIntegrator &integrator = integrators_[s];
      const std::uint32_t    r          = space.mode_count;
      // Every vertex stored: its pairs are at most one a vertex and one an edge (three a triangle).
      const std::size_t patch_vertices = nv - space.candidate_count;
      const std::size_t all_pairs      = std::size_t(nv) + 3 * std::size_t(basis.triangle_count);
      const std::size_t need           = sizeof(double) * (3 * std::size_t(r) * patch_vertices +
                                                           StoredGrams::entry_doubles * all_pairs);
      if (patch_vertices > 0 && memory + need <= limit)
        {
          StoredRows &stored = stored_rows_[s];
          stored.patch_row_of.assign(nv, MODALRT_NONE);
          stored.patch_rows.assign(3 * std::size_t(r) * patch_vertices, 0.0);
          std::uint32_t k = 0;
          for (std::uint32_t v = 0; v < nv; ++v)
            if (space.candidate_index(v) < 0)
              {
                stored.patch_row_of[v] = k;
                patch_row(basis, space, v, 0, r, &stored.patch_rows[3 * std::size_t(r) * k++]);
              }
          memory += need;
        }
      const auto pairs = triangle_pairs(basis, [&](std::uint32_t v) { return stored_row(s, v) != nullptr; });
      StoredGrams &store = stored_grams_[s];
      store.first.assign(std::size_t(nv) + 1, 0);
      store.neighbour.resize(pairs.size());
      store.coupled.assign(pairs.size(), 0);
      store.blocks.assign(StoredGrams::entry_doubles * pairs.size(), 0.0);
      for (std::size_t e = 0; e < pairs.size(); ++e)
        {
          const auto [a, b] = pairs[e];
          ++store.first[a + 1];
          store.neighbour[e] = b;
          double *M = &store.blocks[StoredGrams::entry_doubles * e];
          add_gram_chunks(stored_row(s, a), stored_row(s, b), integrator.g1(), integrator.g2(), r, 0, r, M, M + 9);
          const int ca = space.candidate_index(a), cb = space.candidate_index(b);
          if (ca < 0 || cb < 0)
            continue;
          store.coupled[e] = space.residual_coupling(std::uint32_t(ca), std::uint32_t(cb), M + 18) != ModalSpace::Coupling::none;
          space.residual_coupling(std::uint32_t(cb), std::uint32_t(ca), M + 27);
        }
      for (std::uint32_t v = 0; v < nv; ++v)
        store.first[v + 1] += store.first[v];
    }
}

// The StoredGrams entry of two rows of the active space, -1 if either row is not stored or they
// share no triangle.
std::ptrdiff_t modalrt_kernel::stored_pair(const ProxyRow &a, const ProxyRow &b) const noexcept
{
  if (!a.stored || !b.stored || space_ >= stored_grams_.size())
    return -1;
  return stored_grams_[space_].find(std::min(a.vertex, b.vertex), std::max(a.vertex, b.vertex));
}

// Adds chunks of modes to the pair block of slots i and j (both rows ready) until it is ready or
// `budget` modes are spent (the last chunk may go over); returns the modes added. The chunks are the
// same whoever adds them (the look-ahead, a crossing that found the block unprepared, or the kernel's
// creation for two stored rows: then it is copied, transposed if slot i's vertex is the larger, and
// no mode is spent), so the block does not depend on when it was made.
std::uint32_t modalrt_kernel::add_gram_modes(ProxyState &proxy, std::uint32_t i, std::uint32_t j,
                                             std::uint32_t budget) const noexcept
{
  ProxyGram             &g = proxy.gram(i, j);
  const ModalIntegrator &integrator = integrators_[space_];
  const std::uint32_t    r = integrator.mode_count();
  const ProxyRow        &low = proxy.rows[std::min(i, j)], &high = proxy.rows[std::max(i, j)];
  if (const std::ptrdiff_t e = g.built == 0 ? stored_pair(low, high) : -1; e >= 0)
    {
      const double *stored     = stored_grams_[space_].gram(e);
      const bool    transposed = low.vertex > high.vertex;
      for (int row = 0; row < 3; ++row)
        for (int column = 0; column < 3; ++column)
          {
            const int from        = transposed ? 3 * column + row : 3 * row + column;
            g.M[3 * row + column] = stored[from];
            g.N[3 * row + column] = stored[9 + from];
          }
      g.built = r;
      g.ready = true;
      return 0;
    }
  if (g.built == 0)
    std::fill_n(g.M, 9, 0.0), std::fill_n(g.N, 9, 0.0);
  std::uint32_t done = 0;
  while (done < budget && g.built < r)
    {
      const std::uint32_t first = g.built, last = std::min(r, first + proxy_gram_chunk);
      add_gram_chunks(low.B, i == j ? low.B : high.B, integrator.g1(), integrator.g2(), r, first, last, g.M, g.N);
      g.built = last;
      done += last - first;
    }
  g.ready = g.built == r;
  return done;
}

// The slot of `vertex`'s row as a corner of triangle `corners` the proxy is on or entering: ready
// (finished here if the look-ahead has not done it: a proxy faster than the preparation, or a start)
// and with its displacement u = B q.
std::uint8_t modalrt_kernel::corner_row(Contact &c, std::uint32_t vertex, const std::uint32_t *corners) noexcept
{
  int slot = find_slot(c.proxy, vertex);
  if (slot < 0)
    slot = acquire_row(c, vertex, corners);
  ProxyRow &row = c.proxy.rows[slot];
  if (!row.ready)
    add_row_entries(row, patch_size(basis, vertex));
  row.stamp = c.proxy.crossings;
  dot_rows3(row.B, q_.data(), mode_count(), row.u);
  row.u_stamp = state_stamp_;
  return std::uint8_t(slot);
}

// The pair blocks of the proxy's triangle (finished here where the look-ahead has not prepared
// them), packed for proxy_coupling_block once per triangle entered.
void modalrt_kernel::pack_triangle(Contact &c) noexcept
{
  ProxyState &proxy = c.proxy;
  if (proxy.packed_triangle == proxy.triangle)
    return;
  static constexpr int pairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (int p = 0; p < 6; ++p)
    {
      const std::uint32_t i = proxy.corner_slot[pairs[p][0]], j = proxy.corner_slot[pairs[p][1]];
      if (!proxy.gram(i, j).ready)
        add_gram_modes(proxy, i, j, ~0u);
      const ProxyGram &g = proxy.gram(i, j);
      double          *packed = proxy.packed[p];
      for (int half = 0; half < 2; ++half)
        {
          const double *m = half == 0 ? g.M : g.N;
          double       *out = packed + 6 * half;
          if (i == j) // symmetric: its upper triangle
            out[0] = m[0], out[1] = m[1], out[2] = m[2], out[3] = m[4], out[4] = m[5], out[5] = m[8];
          else // M + M^T
            out[0] = 2.0 * m[0], out[1] = m[1] + m[3], out[2] = m[2] + m[6], out[3] = 2.0 * m[4],
            out[4] = m[5] + m[7], out[5] = 2.0 * m[8];
        }
    }
  // The residual compliance of the corner pairs, as blended_residual reads them for a load with
  // itself (proxy_pair_compliance), packed per unordered pair (ProxyState::residual).
  const ModalSpace &space = basis.spaces[space_];
  proxy.residual_any      = false;
  proxy.residual_linear   = !space.couples_distinct_candidates();
  for (double(&block)[9] : proxy.residual)
    std::fill_n(block, 9, 0.0);
  for (int p = 0; p < 6 && def.use_static_correction; ++p)
    {
      const int k = pairs[p][0], l = pairs[p][1];
      const int ck = proxy.corner(k).candidate, cl = proxy.corner(l).candidate;
      if (ck < 0 || cl < 0)
        continue;
      double *packed = proxy.residual[p];
      if (proxy.residual_linear)
        {
          if (k == l)
            std::copy_n(&space.candidate_compliance[9 * std::size_t(ck)], 9, packed), proxy.residual_any = true;
          continue;
        }
      const ProxyRow      &a = proxy.corner(k), &b = proxy.corner(l);
      const std::ptrdiff_t e = stored_pair(a, b); // the StoredGrams entry: C_kl and C_lk stored
      for (int order = 0; order < (k == l ? 1 : 2); ++order)
        {
          const ProxyRow &from = order == 0 ? a : b, &to = order == 0 ? b : a;
          double          C[9];
          bool            coupled;
          if (e >= 0)
            {
              coupled = stored_grams_[space_].coupled[std::size_t(e)] != 0;
              std::copy_n(stored_grams_[space_].residual(e, from.vertex <= to.vertex), 9, C);
            }
          else
            coupled = space.residual_coupling(std::uint32_t(from.candidate), std::uint32_t(to.candidate), C) !=
                      ModalSpace::Coupling::none;
          if (!coupled)
            continue;
          for (int i = 0; i < 9; ++i)
            packed[i] += C[i];
          proxy.residual_any = true;
        }
    }
  proxy.packed_triangle = proxy.triangle;
}

// The look-ahead of the proxy's triangle (proxy_state.h). The rows kept for the corners of its
// triangles are stamped as wanted now.
void modalrt_kernel::make_lookahead(Contact &c) noexcept
{
  ProxyState         &proxy = c.proxy;
  const std::uint32_t t     = proxy.triangle;
  proxy.ahead_count         = 0;
  proxy.ahead_next          = 0;
  proxy.ahead_triangle      = t;
  std::uint32_t triangle = t;
  double        w[3]     = {proxy.weights[0], proxy.weights[1], proxy.weights[2]};
  while (dot3(proxy.heading, proxy.heading) > 0.0 && proxy.ahead_count < proxy_lookahead)
    {
      const std::uint32_t *from = &basis.triangles[3 * std::size_t(triangle)];
      double               X[3][3], dw[3];
      for (int k = 0; k < 3; ++k)
        std::copy_n(&basis.vertices[3 * std::size_t(from[k])], 3, X[k]);
      if (!barycentric_step(triangle_system(X), proxy.heading, dw))
        break;
      int    exit = -1;
      double s    = HUGE_VAL;
      for (int k = 0; k < 3; ++k)
        if (dw[k] < 0.0 && w[k] / -dw[k] < s)
          s = w[k] / -dw[k], exit = k;
      const std::uint32_t next = exit < 0 ? MODALRT_NONE : basis.adjacency.neighbour(triangle, exit);
      if (next == MODALRT_NONE)
        break;
      const std::uint32_t *to       = &basis.triangles[3 * std::size_t(next)];
      double               entry[3] = {0.0, 0.0, 0.0};
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          if (to[j] == from[k] && k != exit)
            entry[j] = std::max(0.0, w[k] + s * dw[k]);
      std::copy_n(entry, 3, w);
      proxy.ahead[proxy.ahead_count++] = triangle = next;
    }
  if (proxy.ahead_count == 0) // no heading (a start), or it leads out: every way out
    for (int e = 0; e < 3; ++e)
      if (const std::uint32_t next = basis.adjacency.neighbour(t, e); next != MODALRT_NONE)
        proxy.ahead[proxy.ahead_count++] = next;
  for (std::uint32_t j = 0; j < proxy.ahead_count; ++j)
    {
      const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.ahead[j])];
      for (ProxyRow &row : proxy.rows)
        if (row.vertex == corners[0] || row.vertex == corners[1] || row.vertex == corners[2])
          row.stamp = proxy.crossings;
    }
}

// The bounded work of an impedance tick ahead of the proxy: the look-ahead's triangles in order,
// their corners' rows and then their pair blocks, about proxy_prepare_work multiply-adds of each
// (proxy_state.h). Nothing once they are all prepared, until the proxy
// enters another triangle.
void modalrt_kernel::prepare_proxy(Contact &c) noexcept
{
  ProxyState &proxy = c.proxy;
  if (proxy.ahead_triangle != proxy.triangle)
    make_lookahead(c);
  const std::uint32_t *own     = &basis.triangles[3 * std::size_t(proxy.triangle)];
  const std::uint32_t  r       = mode_count();
  std::uint32_t        entries = std::max<std::uint32_t>(1, proxy_prepare_work / (3 * r)), modes = proxy_prepare_work / 24;
  for (; proxy.ahead_next < proxy.ahead_count; ++proxy.ahead_next)
    {
      const std::uint32_t *corners = &basis.triangles[3 * std::size_t(proxy.ahead[proxy.ahead_next])];
      std::uint32_t        slot[3];
      for (int k = 0; k < 3; ++k)
        {
          int s = find_slot(proxy, corners[k]);
          if (s < 0)
            {
              if (entries == 0)
                return;
              s = acquire_row(c, corners[k], own);
            }
          ProxyRow &row = proxy.rows[s];
          if (!row.ready)
            {
              entries -= add_row_entries(row, entries);
              if (!row.ready)
                return;
            }
          slot[k] = std::uint32_t(s);
        }
      for (int k = 0; k < 3; ++k)
        for (int l = k; l < 3; ++l)
          if (!proxy.gram(slot[k], slot[l]).ready)
            {
              if (modes == 0)
                return;
              modes -= std::min(modes, add_gram_modes(proxy, slot[k], slot[l], modes));
              if (!proxy.gram(slot[k], slot[l]).ready)
                return;
            }
    }
}

// The contact's own coupling block from the pair blocks of its triangle (ProxyGram):
// B G B^T = sum_k w_k^2 M_kk + sum_(k<l) w_k w_l (M_kl + M_kl^T), the same for H; 72 multiply-adds
// over the packed upper triangles whatever the number of modes.
void modalrt_kernel::proxy_coupling_block(const Contact &c, double S[9], double Sv[9]) const noexcept
{
  const ProxyState &proxy = c.proxy;
  const double     *w     = proxy.weights;
  const double      ww[6] = {w[0] * w[0], w[1] * w[1], w[2] * w[2], w[0] * w[1], w[0] * w[2], w[1] * w[2]};
  const double(&P)[6][12] = proxy.packed;
  double sum[12];
#pragma omp simd
  for (int e = 0; e < 12; ++e)
    sum[e] = ww[0] * P[0][e] + ww[1] * P[1][e] + ww[2] * P[2][e] + ww[3] * P[3][e] + ww[4] * P[4][e] + ww[5] * P[5][e];
  for (int half = 0; half < 2; ++half)
    {
      const double *t   = sum + 6 * half;
      double       *out = half == 0 ? S : Sv;
      out[0] = t[0], out[1] = t[1], out[2] = t[2];
      out[3] = t[1], out[4] = t[3], out[5] = t[4];
      out[6] = t[2], out[7] = t[4], out[8] = t[5];
    }
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
        proxy.corner_slot[k] = corner_row(c, corners[k], corners);
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
  pack_triangle(c);
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
  // The corners' displacements as the last tick's outputs left them (write_outputs), unless the
  // state moved since (a settle, a switch, a new contact).
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
  // A and A^-1 at the proxy's weights (the walk's few micrometres a tick leave them as they are); a
  // singular A (not met with a passive coupling) leaves the explicit force, as solve_coupling does.
  double S[9], Sv[9], C[9], A[9], A_inverse[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  proxy_coupling_block(c, S, Sv);
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
      if (proxy.face_triangle != proxy.triangle)
        face_normal(c, proxy.face), proxy.face_triangle = proxy.triangle;
      std::copy_n(proxy.face, 3, n);
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
      if (!walk_proxy(c, step))
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
    proxy.lookahead_deferrals = 0, prepare_proxy(c);
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
  if (c.proxy.face_triangle != c.proxy.triangle)
    face_normal(c, c.proxy.face), c.proxy.face_triangle = c.proxy.triangle;
  const double *n = c.proxy.face, normal = -dot3(F, n);
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

// Whether the proxy, on the edge of its triangle opposite `corner`, cannot cross it with `step`: a
// boundary edge, or a crease, where the neighbour across it, as deformed, has the step point back
// across the edge (its corner off the edge would lose weight): each face hands the step to the
// other, and a walk that crossed would come straight back. A crease is not reported where that is
// not known without building a row (the neighbour's corner row not ready in a slot): the walk then
// crosses, and its entry rule catches it.
bool modalrt_kernel::creased(Contact &c, int corner, const double step[3]) noexcept
{
  ProxyState         &proxy = c.proxy;
  const std::uint32_t next  = basis.adjacency.neighbour(proxy.triangle, corner);
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
          if (row.u_stamp != state_stamp_)
            dot_rows3(row.B, q_.data(), mode_count(), row.u), row.u_stamp = state_stamp_;
          u = row.u, off = j;
        }
      for (int d = 0; d < 3; ++d)
        Y[j][d] = basis.vertices[3 * std::size_t(to[j]) + d] + u[d];
    }
  return off >= 0 && barycentric_step(triangle_system(Y), step, dw) && dw[off] < 0.0;
}

// Moves the proxy by `step` (body frame, tangential) over the deformed surface: within a triangle
// by its barycentric weights, across an edge into the neighbouring triangle with what is left of
// the step, at most proxy_edge_budget edges; at a boundary edge it goes along it. True if it moved.
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
bool modalrt_kernel::walk_proxy(Contact &c, const double step[3]) noexcept
{
  ProxyState &proxy = c.proxy;
  double      remaining[3] = {step[0], step[1], step[2]};
  bool        moved        = false;
  int         entry        = -1; // the corner opposite the edge this walk entered the triangle through
  for (std::uint32_t crossing = 0; crossing <= proxy_edge_budget; ++crossing)
    {
      const DeformedTriangle &Y = deformed_triangle(basis, proxy, state_stamp_);
      double                  dw[3];
      if (!barycentric_step(Y.system, remaining, dw))
        break;
      int leaving[2], count = 0; // corners at 0 that the step would make negative
      for (int k = 0; k < 3; ++k)
        if (proxy.weights[k] == 0.0 && dw[k] < 0.0)
          leaving[count++] = k;
      int exit = -1;
      if (count == 2) // at a vertex
        {
          const int v = 3 - leaving[0] - leaving[1];
          auto      turn = [&](int k) {
            double e[3];
            for (int d = 0; d < 3; ++d)
              e[d] = Y.Y[k][d] - Y.Y[v][d];
            return dot3(remaining, e) / norm3(e);
          };
          exit = leaving[0] == entry ? leaving[1]
                 : leaving[1] == entry ? leaving[0]
                 : turn(leaving[0]) <= turn(leaving[1]) ? leaving[0] : leaving[1];
        }
      else if (count == 1 && (leaving[0] == entry || creased(c, leaving[0], remaining)))
        {
          // Along the edge: its ends a, b, the corner off it stays at 0.
          const int k = leaving[0], a = (k + 1) % 3, b = (k + 2) % 3;
          double    e[3];
          for (int d = 0; d < 3; ++d)
            e[d] = Y.Y[b][d] - Y.Y[a][d];
          const double t = dot3(remaining, e) / dot3(e, e);
          dw[k] = 0.0, dw[a] = -t, dw[b] = t;
          if ((proxy.weights[a] == 0.0 && t > 0.0) || (proxy.weights[b] == 0.0 && t < 0.0))
            break; // at a vertex, the edge leads away: nowhere to go from here this time
          int          end;
          const double s = advance(proxy.weights, dw, end);
          moved          = moved || s > 0.0;
          if (end < 0)
            break;
          for (double &r : remaining) // at the vertex: the next pass of the loop leaves it
            r *= 1.0 - s;
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
      const std::uint32_t next = basis.adjacency.neighbour(proxy.triangle, exit);
      if (next == MODALRT_NONE)
        break;
      for (double &r : remaining)
        r *= 1.0 - s;
      const std::uint32_t *from = &basis.triangles[3 * std::size_t(proxy.triangle)];
      const std::uint32_t *to   = &basis.triangles[3 * std::size_t(next)];
      double               w[3] = {0.0, 0.0, 0.0};
      int                  slot[3] = {-1, -1, -1};
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          if (to[j] == from[k])
            w[j] = proxy.weights[k], slot[j] = proxy.corner_slot[k];
      ++proxy.crossings;
      proxy.packed_triangle = MODALRT_NONE;
      for (int j = 0; j < 3; ++j) // the new corner: its row from the look-ahead (or built now)
        if (slot[j] < 0)
          slot[j] = corner_row(c, to[j], to), entry = j;
      for (int j = 0; j < 3; ++j)
        proxy.corner_slot[j] = std::uint8_t(slot[j]), proxy.rows[slot[j]].stamp = proxy.crossings;
      proxy.triangle = next;
      std::copy_n(w, 3, proxy.weights);
      moved = true;
    }
  return moved;
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
