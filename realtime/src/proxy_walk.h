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
  const DeformedTriangle &deformed_triangle(const modalrt_basis &basis, ProxyState &proxy, std::uint64_t state) noexcept;

  // The outward unit normal of the proxy's triangle at rest (the normals the contact uses are the
  // rest ones), kept in the proxy (ProxyState::face) while it stays on that triangle.
  const double *proxy_face_normal(const modalrt_basis &basis, ProxyState &proxy) noexcept;

  // Moves the proxy by `step` (body frame, tangential) over the deformed surface: within a triangle
  // by its barycentric weights, across an edge into the neighbouring triangle with what is left of
  // the step, at most proxy_edge_budget edges; at a boundary edge it goes along it. True if it moved.
  bool walk_proxy(ProxyState &proxy, const double step[3], const ProxyRowView &view) noexcept;
} // namespace modalrt
