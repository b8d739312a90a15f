// The one writer of .mrt basis files (docs/basis-format.md). A producer (the precompute's exporter,
// the kernel's test fixtures) hands it the content of a basis; the writer chooses the sections, their
// order and offsets, derives every header field from the content and computes every CRC.
#pragma once

#include <mrt/format.h>

#include <cstdint>
#include <string>
#include <array>
#include <vector>

namespace mrt
{
  struct BasisSpaceContent
  {
    std::string                name;
    std::vector<double>        eigenvalues;          // r [rad^2/s^2]
    std::vector<double>        damping_ratios;       // r
    std::vector<double>        display_modes;        // 3 nv r (written as f32 or f64)
    std::vector<std::uint32_t> candidates;           // nc, ascending
    std::vector<double>        candidate_modes;      // 3 nc r
    std::vector<double>        candidate_compliance; // 9 nc
    std::vector<double>        cross_compliance;     // (3 nc)^2 or empty: the dense form of version 1.0
    std::vector<std::uint32_t> cross_offsets;        // nc + 1 or empty: neighbours, compressed rows (1.1)
    std::vector<std::uint32_t> cross_neighbours;     // candidate indices, ascending per row
    std::vector<double>        cross_blocks;         // 9 per neighbour [m/N]
    std::vector<double>        felt_stiffness;       // nv or empty: the felt-stiffness map [N/m]
    std::vector<double>        validity_force;       // 3 nv or empty: the validity map [N] (1.2)
    std::vector<double>        far_compliance;       // 3 nc k or empty (1.3): candidate a's 3 x k factor Z_a,
                                                     // row-major [sqrt(m/N)]; C_ab ~ Z_a Z_b^T where no block is stored
    std::vector<double>        participation;        // 6 r or empty
    std::vector<std::uint32_t> validation_cases;     // 2 nval
    std::vector<double>        validation_response;  // 3 nval
  };

  struct BasisTransferContent
  {
    std::uint32_t       to, from;
    std::vector<double> values; // r_to x r_from row-major
  };

  // A section the format does not define (to test that readers skip a newer minor version's sections).
  struct ExtraSection
  {
    std::uint32_t              kind, space, source_space, scalar_type;
    std::uint64_t              count;
    std::vector<unsigned char> bytes;
  };

  // The scene-wide scalars by name; the writer puts each at its place (format.h, scene_scalar).
  struct SceneScalars
  {
    double                patch_radius = 0.;  // rho [m]
    double                mass         = 0.;  // [kg]
    std::array<double, 3> centre_of_mass{};   // [m]
    std::array<double, 9> inertia{};          // about the centre of mass, row-major [kg m^2]
  };

  struct BasisContent
  {
    std::vector<double>        vertices;  // 3 nv [m]
    std::vector<std::uint32_t> triangles; // 3 nt
    std::vector<std::uint32_t> region;    // nv
    std::vector<std::uint32_t> patch_offsets, patch_vertices;
    std::vector<double>        patch_weights;
    SceneScalars               scene_scalars;
    bool                       float64_modes = true;
    std::uint32_t              version_minor = mrt::version_minor;
    std::vector<BasisSpaceContent>    spaces;    // space s is spaces[s]; space 0 is the global space
    std::vector<BasisTransferContent> transfers;
    std::vector<ExtraSection>         extra_sections;

    std::uint32_t vertex_count() const { return std::uint32_t(vertices.size() / 3); }
  };

  // The bytes of the file: sections in the order of the specification, the optional sections that
  // are empty (candidates, cross compliance, far field, participation, validation) left out.
  std::vector<unsigned char> write_basis(const BasisContent &content);
  // Writes it to `path`; false (and a message) if the file cannot be written.
  bool write_basis_file(const std::string &path, const BasisContent &content, std::string *error = nullptr);
  // Recomputes the CRC of every section, the table CRC and the header CRC of a (deliberately edited)
  // file; entries whose data lie outside the buffer, and table entries past its end, are left alone.
  void refresh_checksums(std::vector<unsigned char> &bytes);
} // namespace mrt
