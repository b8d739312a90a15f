// Synthetic bases for the kernel's tests, benchmarks and fuzz seeds (test support: the kernel
// library ships none of it), described as the .mrt writer's content (mrt/include/mrt/writer.h).
//
// make_lattice_cantilever: a physically consistent scene. A small lattice of point masses joined by
// springs (axial, face and body diagonals), clamped at x = 0, with its top face as the display
// surface. Its full eigendecomposition is computed (dense Jacobi, a few hundred DoFs), so every
// number the format stores is exact for this model: modes, the residual compliance of the modes
// left out (static correction), cross compliances, full "FE" validation responses, participation
// factors and least-squares transfers. Space 0 is the global space; space 1 ("tip") owns the VOI
// x >= voi_start * length and has more modes.
//
// make_analytic_plate: a large scene for benchmarks (any r, any number of vertices), with analytic
// mode shapes and a made-up residual compliance; its validation responses are computed from its
// own numbers, so the self-check passes on it too.
#pragma once

#include <mrt/writer.h>

#include <array>
#include <cstdint>
#include <vector>

namespace modalrt
{
  // The writer's names, as the tests use them.
  using mrt::BasisContent;
  using mrt::SceneScalars;
  using mrt::BasisSpaceContent;
  using mrt::BasisTransferContent;
  using mrt::ExtraSection;
  using mrt::refresh_checksums;
  using mrt::write_basis;
  using mrt::write_basis_file;

  struct LatticeOptions
  {
    std::uint32_t nx = 9, ny = 3, nz = 2;  // nodes along the length, width, thickness
    double        length    = 0.2;          // [m]
    double        width     = 0.05;         // [m]
    double        thickness = 0.01;         // [m]
    double        density   = 1200.0;       // [kg/m^3]
    double        stiffness_modulus = 2e7;  // [Pa] spring stiffness = modulus * spacing^2 / length
                                            // (2e7: about 2 mm/N at the tip, a compliant part)
    std::vector<std::uint32_t> modes   = {8, 16}; // r per space (space 0 global, space 1 the tip VOI)
    std::vector<double>        damping = {0.02, 0.05};
    double        voi_start     = 0.6;      // VOI of space 1: x >= voi_start * length
    double        patch_radius  = 0.0;      // [m]
    bool          float64_modes = true;
    bool          cross         = true;     // store CROSS_COMPLIANCE
    bool          transfers     = true;     // store TRANSFER between every ordered pair
    bool          participation = true;
    std::uint32_t candidate_stride = 1;     // every this-many eligible vertex is a candidate
    bool          all_candidates   = false; // every unclamped vertex is a candidate of every space
                                            // (else only the vertices of the space's region)
    std::uint32_t validation_vertices = 3;  // per space, x 3 directions
    bool          felt_stiffness   = false; // store FELT_STIFFNESS: at each candidate of a space the exact
                                            // 1 / (n^T W^T K^-1 W n) [N/m] (n: mrt's area-weighted normal), 0 elsewhere
    bool          validity_force   = false; // store VALIDITY_FORCE (.mrt 1.2), a made-up map with simple numbers: at
                                            // each candidate of a space F_p = p validity_unit (1 + x / length) for
                                            // p = 1, 5, 10 % (x its rest x), except F10 = 1e30 (not reached) in the
                                            // last column (x = length); 0 elsewhere (no value)
    double        validity_unit    = 0.2;   // [N]
    std::uint32_t far_rank         = 0;     // > 0: .mrt 1.3's far field, as the precompute writes it: the cross
                                            // compliance stored only between candidates sharing a display
                                            // triangle (version 1.1's rows), and a made-up FAR_COMPLIANCE of this
                                            // rank for the other pairs (made_up_far_factor); needs `cross`
  };

  // The made-up far-field factor of the lattice (LatticeOptions::far_rank = k): candidate a's 3 x k
  // block Z_a(i, j) = s cos(pi (j + 1) x_a / length + 2 pi i / 3 + y_a / width), smooth in the
  // candidate's rest position (x_a, y_a), s [sqrt(m/N)] the square root of the space's largest own
  // residual compliance entry, so that Z_a Z_b^T is of the size of the residual compliance.
  std::vector<double> made_up_far_factor(const BasisContent &content, std::uint32_t space, std::uint32_t rank,
                                         double length, double width);

  // The residual compliance block C_ab [m/N] (3 x 3 row-major) between candidates a and b (indices)
  // of a space, read from the writer's content the way the specification gives it: a's own at
  // a == b, the dense (1.0) or row (1.1) cross block where stored, else Z_a Z_b^T of FAR_COMPLIANCE
  // (1.3), else 0. The tests' reference, computed apart from the kernel.
  std::array<double, 9> content_residual_block(const BasisSpaceContent &space, std::size_t a, std::size_t b);

  // The static compliance G_ab = B_a Lambda^-1 B_b^T + C_ab [m/N] (3 x 3 row-major) between candidates
  // a and b (indices) of a space, from the content (C_ab by content_residual_block): contacts at
  // candidates settle to u_a = sum_b G_ab F_b.
  std::array<double, 9> content_static_compliance(const BasisSpaceContent &space, std::size_t a, std::size_t b);

  BasisContent make_lattice_cantilever(const LatticeOptions &options = LatticeOptions());

  // The same content with every space's dense CROSS_COMPLIANCE (version 1.0) as version 1.1's
  // compressed rows, every other candidate a neighbour: both forms must give the kernel the same numbers.
  // neighbours_only: keep only the pairs of candidates that share a display triangle (what the
  // precompute stores with its default cross compliance radius, 0).
  BasisContent with_sparse_cross(BasisContent content, bool neighbours_only = false);

  // Display vertex of lattice node (i, j) of the top face.
  inline std::uint32_t lattice_display_vertex(const LatticeOptions &o, std::uint32_t i, std::uint32_t j)
  {
    return j * o.nx + i;
  }

  struct PlateOptions
  {
    std::uint32_t nx = 64, ny = 64;      // display vertices
    double        length = 0.3, width = 0.3; // [m]
    std::uint32_t modes         = 200;   // r of every space
    std::uint32_t spaces        = 2;
    std::uint32_t candidates    = 32;    // per space, with a dense (version 1.0) cross compliance
    bool          every_vertex_candidates = false; // every display vertex a candidate of every space instead,
                                                   // with cross rows to the vertices it shares a triangle with
                                                   // (version 1.1, as the precompute writes them)
    std::uint32_t far_rank      = 0;     // > 0, with every_vertex_candidates: a made-up FAR_COMPLIANCE of
                                         // this rank (.mrt 1.3, made_up_far_factor) couples the other pairs
    bool          float64_modes = false;
    double        patch_radius  = 0.0;   // [m]
  };

  BasisContent make_analytic_plate(const PlateOptions &options = PlateOptions());
} // namespace modalrt
