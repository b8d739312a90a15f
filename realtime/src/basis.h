// The loaded basis: the numbers of a .mrt file in typed arrays, plus what is derived from them once
// at load (vertex normals, the spatial index, bounds used by the snap search).
#pragma once

#include "spatial_grid.h"

#include <modalrt/modalrt.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace modalrt
{
  // One modal space: the reduced basis of one scenario (global space 0, or a VOI).
  struct ModalSpace
  {
    std::string   name;
    std::uint32_t mode_count       = 0; // r
    std::uint32_t candidate_count  = 0; // nc
    std::uint32_t validation_count = 0; // nval
    std::uint32_t cross_count      = 0; // n_cross: 0 or nc

    std::vector<double>        eigenvalues;      // r, lambda = omega^2 [rad^2/s^2]
    std::vector<double>        damping_ratios;   // r
    std::vector<float>         display_modes_f32; // 3 nv r (one of the two is filled)
    std::vector<double>        display_modes_f64;
    std::vector<std::uint32_t> candidates;           // nc, ascending
    std::vector<double>        candidate_modes;      // 3 nc r, B_v per candidate
    std::vector<double>        candidate_compliance; // 9 nc, C_v
    std::vector<double>        cross_compliance;     // (3 n_cross)^2
    std::vector<double>        participation;        // 6 r (empty: not stored)
    std::vector<std::uint32_t> validation_cases;     // 2 nval
    std::vector<double>        validation_response;  // 3 nval

    // max over display vertices of the Frobenius norm of the vertex's 3 x r mode block, so that
    // |u_v| <= max_vertex_mode_norm |q| bounds every displacement (the snap search radius).
    double max_vertex_mode_norm = 0.0;

    // Index of `vertex` among the candidates, -1 if it has no static correction.
    int candidate_index(std::uint32_t vertex) const;
  };

  struct TransferMatrix
  {
    std::uint32_t       to, from;
    std::vector<double> matrix; // r_to x r_from, row-major
  };

  struct SectionRecord
  {
    std::uint32_t kind, space, source_space, scalar_type;
    std::uint64_t offset, count;
    std::uint32_t crc32;
  };
} // namespace modalrt

struct modalrt_basis
{
  std::string   source; // file name (or "<memory>") for messages
  std::uint32_t version_major = 0, version_minor = 0;
  std::uint64_t file_bytes          = 0;
  std::uint32_t vertex_count        = 0; // nv
  std::uint32_t triangle_count      = 0; // nt
  std::uint32_t max_modes           = 0;
  std::uint32_t max_patch_size      = 0;
  std::uint32_t mode_scalar_type    = 0; // format::f32 or format::f64

  std::vector<double>        vertices;  // 3 nv [m]
  std::vector<std::uint32_t> triangles; // 3 nt
  std::vector<std::uint32_t> region;    // nv
  std::vector<std::uint32_t> patch_offsets, patch_vertices;
  std::vector<double>        patch_weights;
  std::array<double, 14>     scene_scalars{}; // rho, mass, centre of mass (3), inertia (9)

  std::vector<modalrt::ModalSpace>  spaces;
  // The TRANSFER matrices the file holds, sorted by (to, from): memory in proportion to the file,
  // not to n_spaces^2 (a crafted table of many spaces cannot make the load allocate a square).
  std::vector<modalrt::TransferMatrix> transfers;
  std::vector<double>                  no_transfer; // empty: what transfer() returns for a missing pair
  std::vector<modalrt::SectionRecord> sections;

  // Derived at load.
  std::vector<double>  normals; // 3 nv unit outward (area-weighted), 0 for isolated vertices
  double               bounds_min[3] = {0, 0, 0}, bounds_max[3] = {0, 0, 0};
  modalrt::SpatialGrid grid;

  std::uint32_t space_count() const { return std::uint32_t(spaces.size()); }
  double        patch_radius() const { return scene_scalars[0]; }
  bool          float64_modes() const { return mode_scalar_type == 3; }
  // T from space `from` into space `to` (r_to x r_from, row-major), empty if absent. Binary search,
  // no allocation (a tick may call it).
  const std::vector<double> &transfer(std::uint32_t to, std::uint32_t from) const
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

  // Row block of the display modes of vertex v in space s, converted to double: out[c r + i].
  void vertex_mode_block(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, double *out);
} // namespace modalrt
