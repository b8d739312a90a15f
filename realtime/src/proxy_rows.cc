// The rows and pair blocks of a sliding contact (proxy_rows.h). They are the same sums whoever makes
// them (the look-ahead, a crossing that found them unprepared, the kernel's creation), so what a
// contact feels does not depend on when they were made.
#include "proxy_rows.h"

#include "dense.h"
#include "triangle_geometry.h"
#include "vector3.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

using namespace modalrt;

int modalrt::find_slot(const ProxyState &proxy, std::uint32_t vertex) noexcept
{
  for (std::uint32_t s = 0; s < proxy_row_slots; ++s)
    if (proxy.rows[s].vertex == vertex)
      return int(s);
  return -1;
}

// A slot for `vertex`'s row, taken from a vertex that is not wanted: never a corner of `keep` (the
// triangle the proxy is on or entering); an empty slot first, else the one wanted longest ago (the
// look-ahead's rows carry the current stamp). A stored row (StoredRows) is read in place, ready at
// once; any other patch row starts empty and is accumulated by add_row_entries. The slot's pair
// blocks are void.
int modalrt::acquire_row(ProxyState &proxy, std::uint32_t vertex, const std::uint32_t *keep, const ProxyRowView &view) noexcept
{
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
  const ModalSpace &space = view.active_space();
  row.clear();
  row.vertex    = vertex;
  row.candidate = space.candidate_index(vertex);
  row.stamp     = proxy.crossings;
  if (const double *stored = view.stored.row(view.basis, view.space, vertex))
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
std::uint32_t modalrt::add_row_entries(ProxyRow &row, std::uint32_t budget, const ProxyRowView &view) noexcept
{
  const std::uint32_t size = patch_size(view.basis, row.vertex), end = std::min(size, row.built + budget);
  const std::uint32_t done = end - row.built;
  add_patch_entries(view.basis, view.active_space(), row.vertex, row.built, end, row.buffer);
  row.built = end;
  row.ready = end == size;
  return done;
}

namespace
{
  // Adds the modes [first, last) of the pair block of rows a and b (a == b: a row's own block) in
  // chunks of proxy_gram_chunk counted from mode 0, so that a block is the same sum whoever makes it.
  // Never inlined: the vectorizer may order a reduction's partial sums differently in an inlined
  // copy (the kernel's creation, with first = 0, took other lanes), and a stored block must be the
  // one a tick would make, to the last bit.
  MODALRT_NOINLINE void add_gram_chunks(const double *a, const double *b, const double *g1, const double *g2, std::uint32_t r,
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

const double *StoredProxyRows::row(const modalrt_basis &basis, std::uint32_t space_index, std::uint32_t vertex) const noexcept
{
  const ModalSpace &space = basis.spaces[space_index];
  if (const int c = space.candidate_index(vertex); c >= 0)
    return &space.candidate_modes[3 * std::size_t(space.mode_count) * std::size_t(c)];
  if (space_index >= rows_.size() || rows_[space_index].patch_row_of.empty())
    return nullptr;
  const StoredRows   &stored = rows_[space_index];
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

// For every space: the patch rows of its display vertices that are not candidates (StoredRows; a
// space whose rows and pair blocks would take the memory past the limit keeps only its
// candidates'), then the pair blocks and residual couplings of every two vertices
// with stored rows that share a triangle, and of each with itself (StoredGrams): 24 r multiply-adds
// a pair, once.
void StoredProxyRows::make(const modalrt_basis &basis, const modalrt::Vector<ModalIntegrator> &integrators,
                           std::size_t limit)
{
  const std::uint32_t nv = basis.vertex_count;
  rows_.resize(basis.space_count());
  grams_.resize(basis.space_count());
  std::size_t memory = 0;
  for (std::uint32_t s = 0; s < basis.space_count(); ++s)
    {
      const ModalSpace      &space      = basis.spaces[s];
      const ModalIntegrator &integrator = integrators[s];
      const std::uint32_t    r          = space.mode_count;
      // Every vertex stored: its pairs are at most one a vertex and one an edge (three a triangle).
      const std::size_t patch_vertices = nv - space.candidate_count;
      const std::size_t all_pairs      = std::size_t(nv) + 3 * std::size_t(basis.triangle_count);
      const std::size_t need           = sizeof(double) * (3 * std::size_t(r) * patch_vertices +
                                                           StoredGrams::entry_doubles * all_pairs);
      if (patch_vertices > 0 && memory + need <= limit)
        {
          StoredRows &stored = rows_[s];
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
      const auto pairs = triangle_pairs(basis, [&](std::uint32_t v) { return row(basis, s, v) != nullptr; });
      StoredGrams &store = grams_[s];
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
          add_gram_chunks(row(basis, s, a), row(basis, s, b), integrator.g1(), integrator.g2(), r, 0, r, M, M + 9);
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

std::ptrdiff_t StoredProxyRows::pair(std::uint32_t space, const ProxyRow &a, const ProxyRow &b) const noexcept
{
  if (!a.stored || !b.stored || space >= grams_.size())
    return -1;
  return grams_[space].find(std::min(a.vertex, b.vertex), std::max(a.vertex, b.vertex));
}

// The chunks of add_gram_modes are the
// same whoever adds them (the look-ahead, a crossing that found the block unprepared, or the kernel's
// creation for two stored rows: then it is copied, transposed if slot i's vertex is the larger, and
// no mode is spent), so the block does not depend on when it was made.
std::uint32_t modalrt::add_gram_modes(ProxyState &proxy, std::uint32_t i, std::uint32_t j, std::uint32_t budget,
                             const ProxyRowView &view) noexcept
{
  ProxyGram             &g = proxy.gram(i, j);
  const ModalIntegrator &integrator = view.integrator;
  const std::uint32_t    r = integrator.mode_count();
  const ProxyRow        &low = proxy.rows[std::min(i, j)], &high = proxy.rows[std::max(i, j)];
  if (const std::ptrdiff_t e = g.built == 0 ? view.stored.pair(view.space, low, high) : -1; e >= 0)
    {
      const double *stored     = view.stored.grams(view.space).gram(e);
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

// A corner's row is ready (finished here if the look-ahead has not done it: a proxy faster than the preparation, or a start)
// and with its displacement u = B q.
std::uint8_t modalrt::corner_row(ProxyState &proxy, std::uint32_t vertex, const std::uint32_t *corners,
                        const ProxyRowView &view) noexcept
{
  int slot = find_slot(proxy, vertex);
  if (slot < 0)
    slot = acquire_row(proxy, vertex, corners, view);
  ProxyRow &row = proxy.rows[slot];
  if (!row.ready)
    add_row_entries(row, patch_size(view.basis, vertex), view);
  row.stamp = proxy.crossings;
  dot_rows3(row.B, view.q, view.mode_count(), row.u);
  row.u_stamp = view.state_stamp;
  return std::uint8_t(slot);
}

// The pair blocks of the proxy's triangle (finished here where the look-ahead has not prepared
// them), packed for proxy_coupling_block once per triangle entered.
void modalrt::pack_triangle(ProxyState &proxy, const ProxyRowView &view, bool use_static_correction) noexcept
{
  if (proxy.packed_triangle == proxy.triangle)
    return;
  static constexpr int pairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (int p = 0; p < 6; ++p)
    {
      const std::uint32_t i = proxy.corner_slot[pairs[p][0]], j = proxy.corner_slot[pairs[p][1]];
      if (!proxy.gram(i, j).ready)
        add_gram_modes(proxy, i, j, ~0u, view);
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
  const ModalSpace &space = view.active_space();
  proxy.residual_any      = false;
  proxy.residual_linear   = !space.couples_distinct_candidates();
  for (double(&block)[9] : proxy.residual)
    std::fill_n(block, 9, 0.0);
  for (int p = 0; p < 6 && use_static_correction; ++p)
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
      const std::ptrdiff_t e = view.stored.pair(view.space, a, b); // the StoredGrams entry: C_kl and C_lk stored
      for (int order = 0; order < (k == l ? 1 : 2); ++order)
        {
          const ProxyRow &from = order == 0 ? a : b, &to = order == 0 ? b : a;
          double          C[9];
          bool            coupled;
          if (e >= 0)
            {
              coupled = view.stored.grams(view.space).coupled[std::size_t(e)] != 0;
              std::copy_n(view.stored.grams(view.space).residual(e, from.vertex <= to.vertex), 9, C);
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

namespace
{
  // The look-ahead of the proxy's triangle (proxy_state.h). The rows kept for the corners of its
  // triangles are stamped as wanted now.
  void make_lookahead(ProxyState &proxy, const modalrt_basis &basis) noexcept
  {
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
} // namespace

// The look-ahead's triangles in order, their corners' rows and then their pair blocks, about
// proxy_prepare_work multiply-adds of each (proxy_state.h). Nothing once they are all prepared,
// until the proxy enters another triangle.
void modalrt::prepare_proxy(ProxyState &proxy, const ProxyRowView &view) noexcept
{
  const modalrt_basis &basis = view.basis;
  if (proxy.ahead_triangle != proxy.triangle)
    make_lookahead(proxy, basis);
  const std::uint32_t *own     = &basis.triangles[3 * std::size_t(proxy.triangle)];
  const std::uint32_t  r       = view.mode_count();
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
              s = acquire_row(proxy, corners[k], own, view);
            }
          ProxyRow &row = proxy.rows[s];
          if (!row.ready)
            {
              entries -= add_row_entries(row, entries, view);
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
              modes -= std::min(modes, add_gram_modes(proxy, slot[k], slot[l], modes, view));
              if (!proxy.gram(slot[k], slot[l]).ready)
                return;
            }
    }
}
