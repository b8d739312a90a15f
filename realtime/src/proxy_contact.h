// The state of a sliding (proxy, god-object) contact: where its proxy sits on the display surface
// (a triangle and barycentric weights) and the contact rows of that triangle's vertices, kept so
// that a slide within a triangle costs a blend and a crossing loads one new row. The kernel's
// functions that move it are in proxy_contact.cc.
#pragma once

#include <modalrt/modalrt.h>

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

  // A vertex's contact row B_v (3 x r, in the kernel's buffer) and its felt displacement B_v q.
  struct ProxyRow
  {
    std::uint32_t vertex    = MODALRT_NONE;
    int           candidate = -1; // index among the active space's candidates, -1 if none
    double       *B         = nullptr;
    double        u[3]      = {0.0, 0.0, 0.0};
  };

  struct ProxyState
  {
    bool          active   = false;
    bool          sliding  = false; // dynamic friction (else sticking)
    std::uint32_t triangle = MODALRT_NONE;
    double        weights[3] = {0.0, 0.0, 0.0}; // of the triangle's corners, in the basis's order
    ProxyRow      rows[3];                       // the corners' rows, in any order
    std::uint32_t rows_space = MODALRT_NONE;     // the space the rows belong to

    // No proxy (the rows keep their buffers).
    void clear()
    {
      active = sliding = false;
      triangle = rows_space = MODALRT_NONE;
      for (int k = 0; k < 3; ++k)
        weights[k] = 0.0, rows[k].vertex = MODALRT_NONE, rows[k].candidate = -1;
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
  // over corners at candidates, from the stored cross compliance (a triangle's corners are always
  // neighbours; a pair beyond the precompute's radius adds nothing); without it a load's own C
  // (`same`) is sum_i w_i C_i (exact at the corners, continuous between) and two loads do not see
  // each other's.
  void blended_residual(const ModalSpace &space, const LoadCorner *a, int na, const LoadCorner *b, int nb, bool same,
                        double C[9]);

  // Barycentric weights of the point of triangle (a, b, c) closest to x (Ericson, Real-Time
  // Collision Detection, 5.1.5): >= 0, sum 1; exactly a corner's when x is at that corner.
  void closest_point_weights(const double x[3], const double a[3], const double b[3], const double c[3], double w[3]);
} // namespace modalrt
