// The loaded basis: the numbers of a .mrt file in typed arrays, plus what is derived from them once
// at load (vertex normals, the spatial index, bounds used by the snap search).
#pragma once

#include "allocator.h"
#include "spatial_grid.h"
#include "surface_adjacency.h"

#include <modalrt/modalrt.h>
#include <mrt/format.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace modalrt
{
  // The .mrt format's constants, owned by mrt/ (include/mrt/format.h).
  namespace format = ::mrt;

  // One modal space: the reduced basis of one scenario (global space 0, or a VOI).
  struct ModalSpace
  {
    std::string   name;
    std::uint32_t mode_count       = 0; // r
    std::uint32_t candidate_count  = 0; // nc
    std::uint32_t validation_count = 0; // nval
    std::uint32_t cross_count      = 0; // candidates with cross compliance rows: 0 or nc

    modalrt::Vector<double>        eigenvalues;      // r, lambda = omega^2 [rad^2/s^2]
    modalrt::Vector<double>        damping_ratios;   // r
    modalrt::Vector<float>         display_modes_f32; // 3 nv r (one of the two is filled)
    modalrt::Vector<double>        display_modes_f64;
    modalrt::Vector<std::uint32_t> candidates;           // nc, ascending
    modalrt::Vector<double>        candidate_modes;      // 3 nc r, B_v per candidate
    modalrt::Vector<double>        candidate_compliance; // 9 nc, C_v
    // The cross compliance between candidates as compressed rows, whichever form the file holds
    // (version 1.1's CROSS_OFFSETS/NEIGHBOURS/BLOCKS, or 1.0's dense CROSS_COMPLIANCE, every other
    // candidate a neighbour): candidate a's neighbours are cross_neighbours[cross_offsets[a] ..
    // cross_offsets[a + 1]), ascending, block (a, b) at the same position of cross_blocks (9 each).
    modalrt::Vector<std::uint32_t> cross_offsets;        // nc + 1 when cross_count = nc
    modalrt::Vector<std::uint32_t> cross_neighbours;
    modalrt::Vector<double>        cross_blocks;
    // The far field (.mrt 1.3, FAR_COMPLIANCE): candidate a's 3 x k factor Z_a at 3 a k, row-major
    // [sqrt(m/N)], so that C_ab ~ Z_a Z_b^T for a pair without a stored block; empty and k = 0 without.
    std::uint32_t                  far_rank = 0; // k
    modalrt::Vector<double>        far_compliance; // 3 nc k
    modalrt::Vector<double>        felt_stiffness;       // nv [N/m], or empty (not in the file)
    modalrt::Vector<double>        validity_force;       // 3 nv [N]: F1, F5, F10 per vertex (0: no value,
                                                         // 1e30: not reached), or empty (not in the file)
    modalrt::Vector<double>        participation;        // 6 r (empty: not stored)
    modalrt::Vector<std::uint32_t> validation_cases;     // 2 nval
    modalrt::Vector<double>        validation_response;  // 3 nval

    // max over display vertices of the Frobenius norm of the vertex's 3 x r mode block, so that
    // |u_v| <= max_vertex_mode_norm |q| bounds every displacement (the snap search radius).
    double max_vertex_mode_norm = 0.0;

    // Index of `vertex` among the candidates, -1 if it has no static correction.
    int candidate_index(std::uint32_t vertex) const;
    // How the kernel couples two candidates beyond the modes (modalrt_basis_pair_coupling's 0, 1, 2).
    enum class Coupling
    {
      none,  // no residual coupling: the modes alone
      exact, // a's own block at a == b, or the stored cross block: the full-FE residual
      far    // the far field's Z_a Z_b^T
    };
    // The one rule for the residual compliance C_ab of candidates a and b (3 x 3 row-major): a's own
    // at a == b, the stored cross block of neighbours, else Z_a Z_b^T when the space has a far field,
    // else none (C untouched). No allocation: 9 k multiply-adds on the stack.
    Coupling residual_coupling(std::uint32_t a, std::uint32_t b, double C[9]) const noexcept;
    // Whether distinct candidates can be coupled (stored rows or a far field): a load spread over
    // several candidates then blends its pairs' blocks; without, only each candidate's own block.
    bool couples_distinct_candidates() const noexcept { return cross_count > 0 || far_rank > 0; }
  };

  struct TransferMatrix
  {
    std::uint32_t       to, from;
    modalrt::Vector<double> matrix; // r_to x r_from, row-major
  };

  struct SectionRecord
  {
    std::uint32_t kind, space, source_space, scalar_type;
    std::uint64_t offset, count;
    std::uint32_t crc32;
  };
} // namespace modalrt

struct modalrt_basis : modalrt::HookAllocated
{
  std::string   source; // file name (or "<memory>") for messages
  std::uint32_t version_major = 0, version_minor = 0;
  std::uint64_t file_bytes          = 0;
  std::uint32_t vertex_count        = 0; // nv
  std::uint32_t triangle_count      = 0; // nt
  std::uint32_t max_modes           = 0;
  std::uint32_t max_patch_size      = 0;
  std::uint32_t mode_scalar_type    = 0; // format::f32 or format::f64

  modalrt::Vector<double>        vertices;  // 3 nv [m]
  modalrt::Vector<std::uint32_t> triangles; // 3 nt
  modalrt::Vector<std::uint32_t> region;    // nv
  modalrt::Vector<std::uint32_t> patch_offsets, patch_vertices;
  modalrt::Vector<double>        patch_weights;
  std::array<double, modalrt::format::scene_scalar::count> scene_scalars{}; // SCENE_SCALARS, by the places format.h names

  modalrt::Vector<modalrt::ModalSpace>  spaces;
  // The TRANSFER matrices the file holds, sorted by (to, from): memory in proportion to the file,
  // not to n_spaces^2 (a crafted table of many spaces cannot make the load allocate a square).
  modalrt::Vector<modalrt::TransferMatrix> transfers;
  modalrt::Vector<double>                  no_transfer; // empty: what transfer() returns for a missing pair
  modalrt::Vector<modalrt::SectionRecord> sections;

  // Derived at load.
  modalrt::Vector<double>  normals; // 3 nv unit outward (area-weighted), 0 for isolated vertices
  double               bounds_min[3] = {0, 0, 0}, bounds_max[3] = {0, 0, 0};
  modalrt::SpatialGrid grid;
  modalrt::SurfaceAdjacency adjacency; // of the display triangles: the sliding proxy's walk

  std::uint32_t space_count() const { return std::uint32_t(spaces.size()); }
  double        patch_radius() const { return scene_scalars[modalrt::format::scene_scalar::patch_radius]; }   // [m]
  double        mass() const { return scene_scalars[modalrt::format::scene_scalar::mass]; }                   // [kg]
  const double *centre_of_mass() const { return &scene_scalars[modalrt::format::scene_scalar::centre_of_mass]; } // 3 [m]
  const double *inertia() const { return &scene_scalars[modalrt::format::scene_scalar::inertia]; } // 9, about the centre of mass [kg m^2]
  bool          float64_modes() const { return mode_scalar_type == 3; }
  // T from space `from` into space `to` (r_to x r_from, row-major), empty if absent. Binary search,
  // no allocation (a tick may call it).
  const modalrt::Vector<double> &transfer(std::uint32_t to, std::uint32_t from) const
  {
    std::size_t low = 0, high = transfers.size();
    while (low < high)
      {
        const std::size_t middle = (low + high) / 2;
        const auto       &t      = transfers[middle];
        if (t.to < to || (t.to == to && t.from < from))
          low = middle + 1;
        else
          high = middle;
      }
    return low < transfers.size() && transfers[low].to == to && transfers[low].from == from ? transfers[low].matrix
                                                                                             : no_transfer;
  }
};

namespace modalrt
{
  // Everything derived from the file once its numbers are checked: normals, bounds, grid, norms.
  void finish_basis(modalrt_basis &basis);

  // The contact row of display vertex v in space s without a stored candidate block: the patch
  // average sum_j w_j Phi_j over v's contact patch, modes [mode_begin, mode_end) only (so that a
  // caller without a 3 x r buffer can take it in pieces): out[c (mode_end - mode_begin) + i - mode_begin].
  // The kernel's contact row and modalrt_basis_contact_compliance both take it from here.
  void patch_row(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, std::uint32_t mode_begin,
                 std::uint32_t mode_end, double *out);

  // The number of display vertices in v's contact patch (its entries).
  inline std::uint32_t patch_size(const modalrt_basis &basis, std::uint32_t v)
  {
    return basis.patch_offsets[v + 1] - basis.patch_offsets[v];
  }

  // Adds entries [entry_begin, entry_end) of v's patch (w_j Phi_j, all r modes) to out (3 x r,
  // zeroed by the caller before the first entry): a row built entry by entry over several calls, in
  // the order patch_row takes them, is patch_row's to the last bit. The sliding contact prepares
  // the rows of the vertices ahead of its proxy this way, a bounded number of entries per tick.
  void add_patch_entries(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v,
                         std::uint32_t entry_begin, std::uint32_t entry_end, double *out);

  // Index 0, 1, 2 of a departure level of 1, 5, 10 % in a vertex's VALIDITY_FORCE entries; -1 for any
  // other level.
  inline int validity_level_index(std::uint32_t percent)
  {
    return percent == 1 ? 0 : percent == 5 ? 1 : percent == 10 ? 2 : -1;
  }

  // The validity force [N] at level index `level` (0, 1, 2) of a load spread over display vertices
  // `corners` with `weights` (a contact at a vertex: that vertex, weight 1; a proxy: its triangle's
  // corners and barycentric weights): sum_k w_k F_k / sum_k w_k over the corners with a weight > 0
  // and a value F_k > 0, so it is continuous as a proxy slides and the stored value at a vertex. 0
  // where no such corner exists or the space has no map (no validity force: never beyond it).
  double blended_validity_force(const ModalSpace &space, const std::uint32_t *corners, const double *weights, int n,
                                int level) noexcept;

  // Row block of the display modes of vertex v in space s, converted to double: out[c r + i].
  void vertex_mode_block(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, double *out);
} // namespace modalrt
