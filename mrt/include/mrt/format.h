// Constants of the .mrt basis file, version 1.3 (docs/basis-format.md): the layout, the header and
// table field offsets, the scalar types and the section kinds. The one place they are written: the
// writer (writer.h), the kernel's loader (realtime/src/basis_loader.cc) and the tests take them from
// here.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mrt
{
  constexpr char          magic[8]          = {'M', 'O', 'D', 'A', 'L', 'R', 'T', '\0'};
  constexpr std::uint32_t version_major     = 1;
  constexpr std::uint32_t version_minor     = 3;
  constexpr std::size_t   header_bytes      = 64;
  constexpr std::size_t   table_entry_bytes = 40;
  constexpr std::size_t   section_alignment = 64;
  constexpr std::uint32_t scene_wide        = 0xFFFFFFFFu; // `space` of scene-wide sections

  // The SCENE_SCALARS section by position: the writer (writer.cc) and the kernel's loader take each
  // scalar's place from here, never from a literal index (docs/basis-format.md lists them).
  namespace scene_scalar
  {
    constexpr std::size_t patch_radius   = 0;  // rho [m]
    constexpr std::size_t mass           = 1;  // [kg]
    constexpr std::size_t centre_of_mass = 2;  // 3 values [m]
    constexpr std::size_t inertia        = 5;  // 9 values, row-major, about the centre of mass [kg m^2]
    constexpr std::size_t count          = 14; // the section's length
  } // namespace scene_scalar
  constexpr std::size_t scene_scalar_count = scene_scalar::count;

  enum ScalarType : std::uint32_t
  {
    u32 = 1,
    f32 = 2,
    f64 = 3,
    u8  = 4
  };

  inline std::size_t scalar_bytes(std::uint32_t type)
  {
    switch (type)
      {
        case u32: return 4;
        case f32: return 4;
        case f64: return 8;
        case u8: return 1;
        default: return 0;
      }
  }

  enum Kind : std::uint32_t
  {
    display_vertices     = 1,
    display_triangles    = 2,
    display_region       = 3,
    patch_offsets        = 4,
    patch_vertices       = 5,
    patch_weights        = 6,
    scene_scalars        = 7,
    space_info           = 16,
    space_name           = 17,
    eigenvalues          = 18,
    damping_ratios       = 19,
    display_modes        = 20,
    candidate_vertices   = 21,
    candidate_modes      = 22,
    candidate_compliance = 23,
    cross_compliance     = 24,
    participation        = 25,
    validation_cases     = 26,
    validation_response  = 27,
    cross_offsets        = 28, // version 1.1: the cross compliance between neighbours, compressed rows
    cross_neighbours     = 29,
    cross_blocks         = 30,
    felt_stiffness       = 31, // version 1.1: the felt-stiffness map
    transfer             = 32,
    validity_force       = 33, // version 1.2: where the linear felt compliance stops holding
    far_compliance       = 34  // version 1.3: a low-rank factor of the residual compliance between far candidates
  };

  // Name of a kind as the specification spells it, "UNKNOWN" for kinds of a newer minor version.
  inline const char *kind_name(std::uint32_t kind)
  {
    switch (kind)
      {
        case display_vertices: return "DISPLAY_VERTICES";
        case display_triangles: return "DISPLAY_TRIANGLES";
        case display_region: return "DISPLAY_REGION";
        case patch_offsets: return "PATCH_OFFSETS";
        case patch_vertices: return "PATCH_VERTICES";
        case patch_weights: return "PATCH_WEIGHTS";
        case scene_scalars: return "SCENE_SCALARS";
        case space_info: return "SPACE_INFO";
        case space_name: return "SPACE_NAME";
        case eigenvalues: return "EIGENVALUES";
        case damping_ratios: return "DAMPING_RATIOS";
        case display_modes: return "DISPLAY_MODES";
        case candidate_vertices: return "CANDIDATE_VERTICES";
        case candidate_modes: return "CANDIDATE_MODES";
        case candidate_compliance: return "CANDIDATE_COMPLIANCE";
        case cross_compliance: return "CROSS_COMPLIANCE";
        case participation: return "PARTICIPATION";
        case validation_cases: return "VALIDATION_CASES";
        case validation_response: return "VALIDATION_RESPONSE";
        case cross_offsets: return "CROSS_OFFSETS";
        case cross_neighbours: return "CROSS_NEIGHBOURS";
        case cross_blocks: return "CROSS_BLOCKS";
        case felt_stiffness: return "FELT_STIFFNESS";
        case transfer: return "TRANSFER";
        case validity_force: return "VALIDITY_FORCE";
        case far_compliance: return "FAR_COMPLIANCE";
        default: return "UNKNOWN";
      }
  }

  inline bool is_known_kind(std::uint32_t kind) { return kind_name(kind)[0] != 'U'; }

  inline bool is_scene_wide_kind(std::uint32_t kind) { return kind >= display_vertices && kind <= scene_scalars; }

  // The scalar type a known kind must have; 0 for DISPLAY_MODES, whose type the header gives.
  inline std::uint32_t expected_scalar_type(std::uint32_t kind)
  {
    switch (kind)
      {
        case display_triangles:
        case display_region:
        case patch_offsets:
        case patch_vertices:
        case space_info:
        case candidate_vertices:
        case cross_offsets:
        case cross_neighbours:
        case validation_cases: return u32;
        case space_name: return u8;
        case display_modes: return 0;
        default: return f64;
      }
  }

  // Header field offsets (bytes).
  namespace header
  {
    constexpr std::size_t magic               = 0;
    constexpr std::size_t version_major       = 8;
    constexpr std::size_t version_minor       = 12;
    constexpr std::size_t header_bytes        = 16;
    constexpr std::size_t section_count       = 20;
    constexpr std::size_t file_bytes          = 24;
    constexpr std::size_t n_spaces            = 32;
    constexpr std::size_t n_display_vertices  = 36;
    constexpr std::size_t n_display_triangles = 40;
    constexpr std::size_t max_modes           = 44;
    constexpr std::size_t max_patch_size      = 48;
    constexpr std::size_t mode_scalar_type    = 52;
    constexpr std::size_t section_table_crc32 = 56;
    constexpr std::size_t header_crc32        = 60;
  } // namespace header

  // The header CRC covers the header's bytes before its own field (0..59).
  constexpr std::size_t header_crc_bytes = header::header_crc32;

  // Section table entry field offsets (bytes).
  namespace entry
  {
    constexpr std::size_t kind         = 0;
    constexpr std::size_t space        = 4;
    constexpr std::size_t source_space = 8;
    constexpr std::size_t scalar_type  = 12;
    constexpr std::size_t offset       = 16;
    constexpr std::size_t count        = 24;
    constexpr std::size_t crc32        = 32;
    constexpr std::size_t reserved     = 36;
  } // namespace entry
} // namespace mrt
