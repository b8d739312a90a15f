// The walk of a sliding contact's proxy over the deformed display surface: its triangle as deformed
// at the modal state, the face normal friction is measured about, and the walk itself, within a
// triangle by its barycentric weights and across edges into the next (taking the new corner's row
// from the proxy's slots, proxy_rows.h).
#pragma once

#include "basis.h"
#include "proxy_rows.h"
#include "proxy_state.h"

#include <cstdint>

namespace modalrt
{
  // The proxy's triangle as deformed (corners at rest + u, without the contact's correction, a
  // common offset) and its system, made once per triangle and modal state (`state`: the kernel's
  // state stamp).
  void deform_triangle(const modalrt_basis &basis, ProxyState &proxy, std::uint64_t state) noexcept;
  inline const DeformedTriangle &deformed_triangle(const modalrt_basis &basis, ProxyState &proxy,
                                                   std::uint64_t state) noexcept
  {
    if (proxy.deformed.triangle != proxy.triangle || proxy.deformed.state != state)
      deform_triangle(basis, proxy, state);
    return proxy.deformed;
  }

  // The outward unit normal of display triangle `triangle` at rest (the normals the contact uses
  // are the rest ones); proxy_face_normal: the proxy's triangle's, kept in the proxy
  // (ProxyState::face) while it stays on that triangle.
  void face_normal(const modalrt_basis &basis, std::uint32_t triangle, double n[3]) noexcept;
  inline const double *proxy_face_normal(const modalrt_basis &basis, ProxyState &proxy) noexcept
  {
    if (proxy.face_triangle != proxy.triangle)
      face_normal(basis, proxy.triangle, proxy.face), proxy.face_triangle = proxy.triangle;
    return proxy.face;
  }

  // Moves the proxy by `step` (body frame, tangential) over the deformed surface: within a triangle
  // by its barycentric weights, across an edge into the neighbouring triangle with what is left of
  // the step, at most proxy_edge_budget edges; at a boundary edge it goes along it. True if it moved.
  bool walk_proxy(ProxyState &proxy, const double step[3], const ProxyRowView &view) noexcept;
} // namespace modalrt
