// A writer of .mrt basis files (docs/basis-format.md) for tests and benchmarks, which make synthetic
// bases with it. The precompute has its own writer (precompute/export_results.cc); both follow the
// same specification, and the loader is the judge.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace modalrt
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
    std::vector<double>        cross_compliance;     // (3 nc)^2 or empty
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

  struct BasisContent
  {
    std::vector<double>        vertices;  // 3 nv [m]
    std::vector<std::uint32_t> triangles; // 3 nt
    std::vector<std::uint32_t> region;    // nv
    std::vector<std::uint32_t> patch_offsets, patch_vertices;
    std::vector<double>        patch_weights;
    std::vector<double>        scene_scalars; // 14
    bool                       float64_modes = true;
    std::uint32_t              version_minor = 0;
    std::vector<BasisSpaceContent>    spaces;
    std::vector<BasisTransferContent> transfers;
    std::vector<ExtraSection>         extra_sections;

    std::uint32_t vertex_count() const { return std::uint32_t(vertices.size() / 3); }
  };

  // The bytes of the file, sections in the order of the specification, empty optional sections left out.
  std::vector<unsigned char> write_basis(const BasisContent &content);
  // Writes it to `path`; false (and a message) if the file cannot be written.
  bool write_basis_file(const std::string &path, const BasisContent &content, std::string *error = nullptr);
  // Recomputes every section CRC, the table CRC and the header CRC of a (deliberately edited) file.
  void refresh_checksums(std::vector<unsigned char> &bytes);
} // namespace modalrt
