// The contact rows and pair blocks of a sliding contact (proxy_state.h): the rows a sliding kernel
// makes at creation (StoredProxyRows), and the work on one proxy's row slots: taking a slot for a
// vertex, accumulating a patch row, the pair blocks of two rows, the corners of the triangle it
// is on (packed for the coupling), and the look-ahead prepared a bounded amount per tick. The
// functions read what they need through a ProxyRowView; none of them knows the kernel.
#pragma once

#include "allocator.h"
#include "basis.h"
#include "modal_integrator.h"
#include "proxy_state.h"

#include <cstddef>
#include <cstdint>

namespace modalrt
{
  // The rows of every space that a sliding kernel holds without building them in a tick
  // (StoredRows, StoredGrams), made at its creation within modalrt_kernel_def.proxy_row_memory.
  class StoredProxyRows
  {
  public:
    // Allocates: for every space, in the basis's order, the patch rows of its display vertices that
    // are not candidates while they fit in `memory_limit` bytes (with their pair blocks), then the
    // pair blocks of the stored rows that share a triangle. `integrators`: one per space.
    void make(const modalrt_basis &basis, const modalrt::Vector<ModalIntegrator> &integrators,
              std::size_t memory_limit);

    // The contact row of `vertex` in space `space` held here or in the basis (a candidate's
    // block), nullptr if none.
    const double *row(const modalrt_basis &basis, std::uint32_t space, std::uint32_t vertex) const noexcept;
    // The StoredGrams entry of two rows of space `space`, -1 if either row is not stored or they
    // share no triangle.
    std::ptrdiff_t pair(std::uint32_t space, const ProxyRow &a, const ProxyRow &b) const noexcept;
    const StoredGrams &grams(std::uint32_t space) const noexcept { return grams_[space]; }

  private:
    modalrt::Vector<StoredRows>  rows_;  // per space (sliding contacts only)
    modalrt::Vector<StoredGrams> grams_; // per space (sliding contacts only)
  };

  // What the work on a proxy's rows reads: the basis and its active space, the modal state there
  // (q, and the kernel's stamp that changes with it), the space's integrator, the stored rows.
  struct ProxyRowView
  {
    const modalrt_basis   &basis;
    std::uint32_t          space;
    const double          *q;
    std::uint64_t          state_stamp;
    const ModalIntegrator &integrator;
    const StoredProxyRows &stored;

    const ModalSpace &active_space() const noexcept { return basis.spaces[space]; }
    std::uint32_t     mode_count() const noexcept { return basis.spaces[space].mode_count; }
  };

  // The slot holding `vertex`'s row (ready or not), -1 if none.
  int find_slot(const ProxyState &proxy, std::uint32_t vertex) noexcept;

  // A slot for `vertex`'s row, taken from a vertex that is not wanted: never a corner of `keep` (the
  // triangle the proxy is on or entering); an empty slot first, else the one wanted longest ago (the
  // look-ahead's rows carry the current stamp). A stored row is read in place, ready at once; any
  // other patch row starts empty and is accumulated by add_row_entries. The slot's pair blocks are
  // void.
  int acquire_row(ProxyState &proxy, std::uint32_t vertex, const std::uint32_t *keep, const ProxyRowView &view) noexcept;

  // Accumulates up to `budget` more patch entries into a row that is not ready; returns how many.
  std::uint32_t add_row_entries(ProxyRow &row, std::uint32_t budget, const ProxyRowView &view) noexcept;

  // Adds chunks of modes to the pair block of slots i and j (both rows ready) until it is ready or
  // `budget` modes are spent (the last chunk may go over); returns the modes added.
  std::uint32_t add_gram_modes(ProxyState &proxy, std::uint32_t i, std::uint32_t j, std::uint32_t budget,
                               const ProxyRowView &view) noexcept;

  // The slot of `vertex`'s row as a corner of triangle `corners` the proxy is on or entering: ready
  // and with its displacement u = B q.
  std::uint8_t corner_row(ProxyState &proxy, std::uint32_t vertex, const std::uint32_t *corners,
                          const ProxyRowView &view) noexcept;

  // The pair blocks and residual compliances of the proxy's triangle, packed once per triangle
  // entered (ProxyState::packed, ProxyState::residual; the residuals zero without
  // `use_static_correction`).
  void pack_triangle(ProxyState &proxy, const ProxyRowView &view, bool use_static_correction) noexcept;

  // The contact's own coupling blocks B G B^T (S) and B H B^T (Sv) at the proxy's weights, from the
  // pair blocks of its triangle (ProxyGram) packed by pack_triangle: no pass over the modes.
  // B G B^T = sum_k w_k^2 M_kk + sum_(k<l) w_k w_l (M_kl + M_kl^T), the same for H; 72 multiply-adds
  // over the packed upper triangles whatever the number of modes.
  inline void proxy_coupling_block(const ProxyState &proxy, double S[9], double Sv[9]) noexcept
  {
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

  // The bounded work of an impedance tick ahead of the proxy (proxy_state.h, proxy_prepare_work).
  void prepare_proxy(ProxyState &proxy, const ProxyRowView &view) noexcept;
} // namespace modalrt
