// The state of a sliding (proxy, god-object) contact: where its proxy sits on the display surface
// (a triangle and barycentric weights) and the contact rows of the vertices around it: the
// triangle's corners, and the vertices the proxy may enter within two edge crossings, prepared
// ahead a bounded amount per tick, so that a slide within a triangle costs a blend and a crossing
// finds the new corner's row ready. Its rows are made in proxy_rows.h, its walk in proxy_walk.h, and
// the kernel's functions that move it are in proxy_contact.cc.
#pragma once

#include "allocator.h"
#include "triangle_geometry.h"

#include <modalrt/modalrt.h>

#include <cstddef>
#include <cstdint>

namespace modalrt
{
  struct ModalSpace;

  // Triangle edges a proxy may cross in one tick (bounded work; a faster HIP is followed over the
  // next ticks).
  constexpr std::uint32_t proxy_edge_budget = 4;
  // Friction passes per tick: the first decides stick or slide, the others follow the curvature of
  // the deformed surface to the friction cone's edge.
  constexpr int proxy_passes = 3;
  // A sliding proxy has reached the cone's edge once the tangential force exceeds mu_d F_n by at most
  // this fraction of itself. One step leaves about 1e-4 (the walk is on the deformed triangle, the
  // force split along its normal at rest), so a flat stretch takes one walk a tick, not three; 1e-3
  // of the friction force is far below what a hand tells apart (realtime/README.md, "Cost").
  constexpr double proxy_friction_tolerance = 1e-3;
  // The look-ahead of a proxy on triangle t: the triangles it is expected to enter next, whose
  // corners' rows and pair blocks are prepared before it gets there. With a heading (its last step
  // over the surface) the next proxy_lookahead triangles that a straight line from the proxy along
  // it crosses into (at rest); without one (a start) the triangles across t's edges.
  constexpr std::uint32_t proxy_lookahead = 3;
  // A tick that enters a triangle does the crossing's own work and puts the look-ahead off to the
  // next tick; a proxy that enters triangles on consecutive ticks (a path past a vertex, or along
  // the short side of thin triangles) gets it after this many such ticks in a row. With one, 43 % of
  // the ticks entering a triangle on bench-kernel-tick's plates also made the look-ahead (the
  // crossings come in pairs there: an edge of a cell, then its diagonal).
  constexpr std::uint8_t proxy_lookahead_deferrals = 3;
  // Rows a sliding contact keeps (its buffers are sized at kernel creation): the three corners, one
  // new corner per look-ahead triangle, and six more, so that the rows of the triangles just left
  // stay while they are not needed elsewhere (a proxy going back finds them).
  constexpr std::uint32_t proxy_row_slots = 12;
  constexpr std::uint32_t proxy_slot_pairs = proxy_row_slots * (proxy_row_slots + 1) / 2;
  // The bounded work of an impedance tick ahead of the proxy, about proxy_prepare_work multiply-adds
  // whatever r: patch entries (one display vertex's 3 x r modes times its patch weight, 3 r
  // multiply-adds each, at least one) added to the look-ahead's rows that are not ready (a
  // candidate's row is its stored block, ready at once), then modes of their pair blocks (24
  // multiply-adds a mode, in chunks of proxy_gram_chunk modes: the last chunk may go over). Sliding
  // at 0.1 m/s over bench-kernel-tick's plate at r = 200 that is about one tick in eight, a few us
  // each; a smaller budget spreads the same work over more ticks and lifts the median tick
  // (realtime/README.md, "Cost").
  constexpr std::uint32_t proxy_prepare_work = 6000;
  constexpr std::uint32_t proxy_gram_chunk   = 64;
  // The memory a sliding kernel spends at creation by default (modalrt_kernel_def.proxy_row_memory
  // = 0) on the contact rows of the display vertices that are not candidates (their patch averages,
  // 3 r doubles each) and on the pair blocks of the vertices sharing a triangle (StoredGrams), over
  // all spaces in the basis's order: about 4.8 kB a vertex at r = 200, so a basis of 11 160 display
  // vertices whose three spaces sample their candidates takes 160 MB of rows and 39 MB of pair
  // blocks at r = 200.
  constexpr std::uint32_t proxy_default_row_memory_mib = 256;

  // A vertex's contact row B_v (3 x r) in the active space: the candidate's CANDIDATE_MODES block
  // (read in place) or the patch average, accumulated in the slot's own buffer.
  struct ProxyRow
  {
    std::uint32_t vertex    = MODALRT_NONE;
    int           candidate = -1; // index among the active space's candidates, -1 if none
    const double *B         = nullptr; // the row when ready: stored (StoredRows), or `buffer`
    double       *buffer    = nullptr; // this slot's 3 x max_modes doubles (the kernel's)
    std::uint32_t built     = 0; // patch entries accumulated into buffer so far
    bool          ready     = false;
    bool          stored    = false; // B is the space's stored row: its pair blocks are in StoredGrams
    std::uint32_t stamp     = 0; // the proxy's crossing count when last wanted (eviction order)
    double        u[3]      = {0.0, 0.0, 0.0}; // B_v q: kept for the triangle's corners
    std::uint64_t u_stamp   = 0; // the kernel's state stamp u was taken at (0: never)

    void clear()
    {
      vertex = MODALRT_NONE, candidate = -1, B = nullptr, built = 0, ready = stored = false, stamp = 0, u_stamp = 0;
    }
  };

  // The residual compliance of a pair of a triangle's corners as a proxy's own load reads it.
  struct ProxyResidual
  {
    enum Kind : std::uint8_t
    {
      none, // no correction between them
      pair, // the stored block C(k, l), weighted by w_k w_l
      own   // (no cross compliance) a corner's own C_k, weighted by w_k
    };
    Kind   kind = none;
    double C[9];
  };

  // The pair block of two rows (slots i <= j): M = B_i G B_j^T and N = B_i H B_j^T with the
  // integrator's per-tick gains G = diag(g1), H = diag(g2) (symmetric when i = j), accumulated over
  // the modes in chunks of proxy_gram_chunk. A contact's own coupling block at weights w is
  // sum_k w_k^2 M_kk + sum_(k<l) w_k w_l (M_kl + M_kl^T) over its triangle's corners: no pass over
  // the modes while the proxy slides within a triangle.
  struct ProxyGram
  {
    double        M[9], N[9];
    std::uint32_t built = 0; // modes accumulated
    bool          ready = false;

    void clear() { built = 0, ready = false; }
  };

  // The contact rows of a space's display vertices that a sliding kernel holds without building
  // them in a tick: a candidate's CANDIDATE_MODES block (in the basis), and, made at creation within
  // modalrt_kernel_def.proxy_row_memory, every other vertex's patch average (patch_row's, to the last bit).
  struct StoredRows
  {
    modalrt::Vector<std::uint32_t> patch_row_of; // per display vertex: its index in patch_rows, or MODALRT_NONE
    modalrt::Vector<double>        patch_rows;   // 3 r doubles per vertex that is not a candidate
  };

  // What a sliding contact reads of two vertices of a space with stored rows that share a display
  // triangle (or of such a vertex with itself), made at kernel creation: their pair blocks and their
  // residual coupling. A crossing between them then copies what the look-ahead has already touched,
  // instead of summing over the modes or searching the cross rows in the tick (realtime/README.md,
  // "Cost"). Entry e of vertex a is the pair (a, neighbour[e]) with neighbour[e] >= a.
  struct StoredGrams
  {
    // Per entry: M and N of ProxyGram with B_a on the left (summed in the look-ahead's chunks), then
    // the residual coupling C_ab and C_ba as ModalSpace::residual_coupling gives them (zero unless
    // both are candidates).
    static constexpr std::size_t entry_doubles = 36;

    modalrt::Vector<std::uint32_t> first;     // per display vertex, its first entry (vertex_count + 1)
    modalrt::Vector<std::uint32_t> neighbour; // per entry
    modalrt::Vector<std::uint8_t>  coupled;   // per entry: 1 if residual_coupling is not none
    modalrt::Vector<double>        blocks;    // entry_doubles per entry

    // The entry of the pair (a, b), a <= b, or -1 when they share no triangle or a row is not stored.
    std::ptrdiff_t find(std::uint32_t a, std::uint32_t b) const
    {
      if (first.empty())
        return -1;
      for (std::uint32_t e = first[a]; e < first[a + 1]; ++e)
        if (neighbour[e] == b)
          return std::ptrdiff_t(e);
      return -1;
    }
    const double *gram(std::ptrdiff_t e) const { return &blocks[entry_doubles * std::size_t(e)]; }
    // C_ab if `forward`, else C_ba.
    const double *residual(std::ptrdiff_t e, bool forward) const { return gram(e) + (forward ? 18 : 27); }
  };

  // The proxy's triangle as deformed at a modal state (ProxyState::deformed).
  struct DeformedTriangle
  {
    std::uint32_t  triangle = MODALRT_NONE;
    std::uint64_t  state    = 0; // the kernel's state stamp
    double         Y[3][3];      // corners at rest + B_k q
    TriangleSystem system;
  };

  struct ProxyState
  {
    bool          active   = false;
    bool          sliding  = false; // dynamic friction (else sticking)
    std::uint8_t  lookahead_deferrals = 0; // ticks in a row that entered a triangle and put off the look-ahead
    std::uint32_t triangle = MODALRT_NONE;
    double        weights[3] = {0.0, 0.0, 0.0}; // of the triangle's corners, in the basis's order
    ProxyRow      rows[proxy_row_slots];         // rows of the vertices around the proxy, any order
    ProxyGram    *grams = nullptr;               // proxy_slot_pairs pair blocks (the kernel's)
    std::uint8_t  corner_slot[3] = {0, 0, 0};    // the slots of the triangle's corners (basis order)
    std::uint32_t rows_space = MODALRT_NONE;     // the space the rows belong to
    std::uint32_t crossings  = 0;                // triangles entered (the slots' stamps)
    std::uint32_t ahead[proxy_lookahead];        // the look-ahead of `triangle` (triangles)
    std::uint32_t ahead_count = 0, ahead_next = 0; // its length; the first not known prepared
    std::uint32_t ahead_triangle = MODALRT_NONE;   // the triangle it was made for
    double        heading[3] = {0.0, 0.0, 0.0};    // the proxy's last step over the surface [m] body
    // The triangle's pair blocks packed for the coupling: per corner pair (00, 11, 22, 01, 02, 12)
    // the upper triangle of M_kk (or of M_kl + M_kl^T), then of N.
    double        packed[6][12];
    // The residual compliance of the triangle's own load, packed like `packed`: per corner pair
    // (00, 11, 22, 01, 02, 12) C_kk, or C_kl + C_lk, each the pair's residual coupling (stored or far
    // field; zero where there is none), weighted by w_k w_l; or, in a space that couples no distinct
    // candidates (residual_linear), each corner's own C_k weighted by w_k (the pairs 01, 02, 12 zero).
    double        residual[6][9];
    bool          residual_any    = false;        // any of them not zero
    bool          residual_linear = false;
    std::uint32_t packed_triangle = MODALRT_NONE; // the triangle both were made for
    double        face[3] = {0.0, 0.0, 0.0};      // face_normal of face_triangle
    std::uint32_t face_triangle = MODALRT_NONE;
    DeformedTriangle deformed;                    // of the triangle the walk is on, this tick

    const ProxyRow &corner(int k) const { return rows[corner_slot[k]]; }
    ProxyRow       &corner(int k) { return rows[corner_slot[k]]; }
    static std::uint32_t pair(std::uint32_t i, std::uint32_t j) { return i <= j ? j * (j + 1) / 2 + i : i * (i + 1) / 2 + j; }
    ProxyGram           &gram(std::uint32_t i, std::uint32_t j) { return grams[pair(i, j)]; }
    const ProxyGram     &gram(std::uint32_t i, std::uint32_t j) const { return grams[pair(i, j)]; }

    // No proxy (the rows and pair blocks keep their buffers).
    void clear()
    {
      active = sliding = false;
      lookahead_deferrals = 0;
      triangle = rows_space = ahead_triangle = packed_triangle = face_triangle = deformed.triangle = MODALRT_NONE;
      crossings = ahead_count = ahead_next = 0;
      for (int k = 0; k < 3; ++k)
        weights[k] = heading[k] = 0.0, corner_slot[k] = 0;
      for (ProxyRow &row : rows)
        row.clear();
      for (std::uint32_t p = 0; grams && p < proxy_slot_pairs; ++p)
        grams[p].clear();
    }
  };

  // One corner of a load spread over display vertices (a contact at a vertex: that vertex, weight 1;
  // a proxy: its triangle's corners and barycentric weights): its index among the space's
  // candidates (-1: none) and its weight.
  struct LoadCorner
  {
    int    candidate;
    double weight;
  };

  // The residual compliance C_ab [m/N] (3 x 3) between two such loads: sum_i sum_j w_i w_j C(i, j)
  // over corners at candidates, C(i, j) the space's residual coupling (ModalSpace::residual_coupling:
  // the stored cross compliance, where a triangle's corners are always neighbours; the far field's
  // Z_i Z_j^T for a pair beyond the precompute's radius, or nothing without one); in a space that
  // couples no distinct candidates a load's own C (`same`) is sum_i w_i C_i (exact at the corners,
  // continuous between) and two loads do not see each other's. True when every weighted pair of
  // candidates was coupled exactly (own or stored blocks): the full-FE residual of the loads.
  bool blended_residual(const ModalSpace &space, const LoadCorner *a, int na, const LoadCorner *b, int nb, bool same,
                        double C[9]);
} // namespace modalrt
