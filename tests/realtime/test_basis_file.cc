// The .mrt reader and writer: the specification's worked example byte for byte, a round trip of
// every section, forward compatibility, and corrupt files rejected with a message naming the section.
#include "test_support.h"

#include <mrt/crc32.h>
#include <mrt/format.h>

#include <cstring>

using modalrt::BasisContent;

namespace
{
  template <typename T>
  void put(std::vector<unsigned char> &bytes, std::size_t offset, T value)
  {
    std::memcpy(bytes.data() + offset, &value, sizeof(T));
  }

  template <typename T>
  T get(const std::vector<unsigned char> &bytes, std::size_t offset)
  {
    T value;
    std::memcpy(&value, bytes.data() + offset, sizeof(T));
    return value;
  }

  // The section table entry of (kind, space): its byte offset in the file.
  std::size_t entry_of(const std::vector<unsigned char> &bytes, std::uint32_t kind, std::uint32_t space)
  {
    const std::uint32_t n = get<std::uint32_t>(bytes, 20);
    for (std::uint32_t k = 0; k < n; ++k)
      {
        const std::size_t e = 64 + 40 * std::size_t(k);
        if (get<std::uint32_t>(bytes, e) == kind && get<std::uint32_t>(bytes, e + 4) == space)
          return e;
      }
    std::fprintf(stderr, "no section %u of space %u\n", kind, space);
    std::exit(1);
  }

  // Loads `bytes`; returns the status and leaves the message in `message`.
  int try_load(const std::vector<unsigned char> &bytes, std::string &message)
  {
    modalrt_basis *basis  = nullptr;
    const int      status = modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis);
    message               = modalrt_last_error_message();
    ENSURE((status == MODALRT_OK) == (basis != nullptr));
    modalrt_basis_destroy(basis);
    return status;
  }

  void ensure_rejected(const std::vector<unsigned char> &bytes, int expected_status, const char *expected_text)
  {
    std::string message;
    const int   status = try_load(bytes, message);
    test::report(status == expected_status && message.find(expected_text) != std::string::npos, __FILE__, __LINE__,
                 std::string("expected ") + modalrt_status_name(expected_status) + " mentioning '" + expected_text +
                   "', got " + modalrt_status_name(status) + ": " + message);
    std::printf("  rejected as expected: %s\n", message.c_str());
  }

  // The worked example of docs/basis-format.md: 1 space, 4 vertices, 2 triangles, r = 2, f64 modes.
  BasisContent worked_example()
  {
    BasisContent c;
    c.vertices       = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    c.triangles      = {0, 1, 2, 0, 2, 3};
    c.region         = {0, 0, 0, 0};
    c.patch_offsets  = {0, 1, 2, 3, 4};
    c.patch_vertices = {0, 1, 2, 3};
    c.patch_weights  = {1, 1, 1, 1};
    c.scene_scalars.mass = 1.0;
    modalrt::BasisSpaceContent s;
    s.name           = "global";
    s.eigenvalues    = {100.0, 400.0};
    s.damping_ratios = {0.01, 0.01};
    s.display_modes.assign(24, 0.1);
    s.participation.assign(12, 0.0);
    c.spaces.push_back(s);
    return c;
  }

  void crc_check_value()
  {
    ENSURE(mrt::crc32("123456789", 9) == 0xCBF43926u);
    // Fed in pieces, as the precompute's partial-result checksums feed it.
    ENSURE(mrt::crc32_update(mrt::crc32_update(0, "1234", 4), "56789", 5) == 0xCBF43926u);
  }

  void worked_example_layout()
  {
    const std::vector<unsigned char> bytes = modalrt::write_basis(worked_example());
    ENSURE(bytes.size() == 1760);
    const unsigned char expected[48] = {0x4d, 0x4f, 0x44, 0x41, 0x4c, 0x52, 0x54, 0x00, 0x01, 0x00, 0x00, 0x00,
                                        0x03, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x00, 0x0d, 0x00, 0x00, 0x00,
                                        0xe0, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
                                        0x04, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00};
    ENSURE(std::memcmp(bytes.data(), expected, 48) == 0);
    const std::uint64_t offsets[13] = {640, 768, 832, 896, 960, 1024, 1088, 1216, 1280, 1344, 1408, 1472, 1664};
    for (int k = 0; k < 13; ++k)
      ENSURE(get<std::uint64_t>(bytes, 64 + 40 * k + 16) == offsets[k]);
    std::string message;
    ENSURE(try_load(bytes, message) == MODALRT_OK);
  }

  // Every number written comes back, for float64 and float32 display modes.
  void round_trip(bool float64)
  {
    modalrt::LatticeOptions options;
    options.float64_modes = float64;
    options.patch_radius  = 0.03;
    const BasisContent c  = modalrt::make_lattice_cantilever(options);
    modalrt_basis     *b  = test::load(c);

    modalrt_basis_info info;
    ENSURE(modalrt_basis_get_info(b, &info) == MODALRT_OK);
    ENSURE(info.space_count == 2 && info.display_vertex_count == c.vertex_count());
    ENSURE(info.display_triangle_count == c.triangles.size() / 3);
    ENSURE(info.max_modes == 16 && info.mode_scalar_bytes == (float64 ? 8u : 4u));
    ENSURE(info.max_patch_size > 1);
    ENSURE(info.patch_radius == 0.03 && info.mass == c.scene_scalars.mass);
    ENSURE(std::memcmp(modalrt_basis_display_vertices(b), c.vertices.data(), c.vertices.size() * 8) == 0);
    ENSURE(std::memcmp(modalrt_basis_display_triangles(b), c.triangles.data(), c.triangles.size() * 4) == 0);
    ENSURE(std::memcmp(modalrt_basis_display_regions(b), c.region.data(), c.region.size() * 4) == 0);
    for (std::uint32_t s = 0; s < 2; ++s)
      {
        modalrt_space_info si;
        ENSURE(modalrt_basis_get_space_info(b, s, &si) == MODALRT_OK);
        ENSURE(std::string(si.name) == c.spaces[s].name);
        ENSURE(si.mode_count == c.spaces[s].eigenvalues.size());
        ENSURE(si.candidate_count == c.spaces[s].candidates.size() && si.cross_count == si.candidate_count);
        ENSURE(si.validation_count == c.spaces[s].validation_cases.size() / 2 && si.has_participation == 1);
        ENSURE(std::memcmp(modalrt_basis_eigenvalues(b, s), c.spaces[s].eigenvalues.data(), 8 * si.mode_count) == 0);
        ENSURE(std::memcmp(modalrt_basis_candidates(b, s), c.spaces[s].candidates.data(), 4 * si.candidate_count) == 0);
      }
    ENSURE(modalrt_basis_has_transfer(b, 1, 0) == 1 && modalrt_basis_has_transfer(b, 0, 1) == 1);
    // Normals of the top face point up (+z).
    const double *n = modalrt_basis_display_normals(b);
    for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
      ENSURE_NEAR(n[3 * v + 2], 1.0, 1e-12);
    modalrt_basis_destroy(b);
  }

  // A newer minor version with a section kind this reader does not know: accepted, section skipped.
  void newer_minor_version()
  {
    BasisContent c  = worked_example();
    c.version_minor = mrt::version_minor + 1;
    c.extra_sections.push_back({99, mrt::scene_wide, mrt::scene_wide, 3, 2,
                                std::vector<unsigned char>(16, 0x11)});
    std::string message;
    ENSURE(try_load(modalrt::write_basis(c), message) == MODALRT_OK);
  }

  void corrupt_files()
  {
    using namespace mrt;
    modalrt::LatticeOptions options;
    options.patch_radius                  = 0.03;
    const std::vector<unsigned char> good = modalrt::write_basis(modalrt::make_lattice_cantilever(options));
    std::string                      message;
    ENSURE(try_load(good, message) == MODALRT_OK);

    auto bytes = good;
    bytes[1]   = 'X';
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "bad magic");

    bytes = good;
    put<std::uint32_t>(bytes, 8, 2);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "format version 2.");

    bytes = good;
    bytes.resize(good.size() - 100);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "truncated");
    bytes.resize(40);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "truncated");

    bytes = good;
    bytes[33] ^= 0x01; // n_spaces, header CRC not updated
    ensure_rejected(bytes, MODALRT_ERROR_CHECKSUM, "header checksum");

    bytes = good;
    bytes[64 + 40 + 24] ^= 0x01; // a count in the table
    ensure_rejected(bytes, MODALRT_ERROR_CHECKSUM, "section table checksum");

    const std::size_t modes = entry_of(good, display_modes, 1);
    bytes                   = good;
    bytes[get<std::uint64_t>(good, modes + 16) + 17] ^= 0x40;
    ensure_rejected(bytes, MODALRT_ERROR_CHECKSUM, "DISPLAY_MODES of space 1 'tip': checksum mismatch");

    // Valid checksums around invalid numbers: the value checks catch them.
    bytes = good;
    put<double>(bytes, get<std::uint64_t>(good, entry_of(good, eigenvalues, 0) + 16) + 8, std::nan(""));
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_VALUE, "EIGENVALUES of space 0 'global': value nan at index 1 is not finite");

    // Two sections sharing their bytes (the crafted-file memory bound of docs/reliability.md): the
    // damping ratios of space 0 pointed at its eigenvalues (same count and type, valid CRCs).
    bytes = good;
    put<std::uint64_t>(bytes, entry_of(good, damping_ratios, 0) + 16, get<std::uint64_t>(good, entry_of(good, eigenvalues, 0) + 16));
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "sections overlap");

    // Finite but absurd: an eigenvalue of 1e300 and a mode entry of 1e200 are refused.
    bytes = good;
    put<double>(bytes, get<std::uint64_t>(good, entry_of(good, eigenvalues, 0) + 16) + 8, 1e300);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_VALUE, "EIGENVALUES of space 0 'global': value 1.0000000000000001e+300 at index 1 is beyond +-1e20");
    bytes = good;
    put<double>(bytes, get<std::uint64_t>(good, entry_of(good, display_modes, 0) + 16) + 8 * 5, -1e200);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_VALUE, "DISPLAY_MODES of space 0 'global': value -9.9999999999999997e+199 at index 5 is beyond +-1e20");

    bytes = good;
    put<double>(bytes, get<std::uint64_t>(good, entry_of(good, display_modes, 0) + 16) + 8 * 5, HUGE_VAL);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_VALUE, "DISPLAY_MODES of space 0 'global'");

    bytes = good;
    put<std::uint32_t>(bytes, get<std::uint64_t>(good, entry_of(good, display_triangles, scene_wide) + 16) + 4, 100000);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "DISPLAY_TRIANGLES: vertex index 100000");

    bytes = good;
    put<double>(bytes, get<std::uint64_t>(good, entry_of(good, patch_weights, scene_wide) + 16), 0.75);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_VALUE, "PATCH_WEIGHTS");

    bytes = good;
    put<std::uint32_t>(bytes, entry_of(good, display_modes, 0), 77); // DISPLAY_MODES of space 0 disappears
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "mandatory section DISPLAY_MODES of space 0 'global' is missing");

    bytes = good;
    put<std::uint64_t>(bytes, entry_of(good, eigenvalues, 0) + 16, get<std::uint64_t>(good, entry_of(good, eigenvalues, 0) + 16) + 8);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "not a multiple of 64");

    bytes = good;
    put<std::uint32_t>(bytes, get<std::uint64_t>(good, entry_of(good, validation_cases, 1) + 16) + 4, 3);
    modalrt::refresh_checksums(bytes);
    ensure_rejected(bytes, MODALRT_ERROR_FORMAT, "VALIDATION_CASES of space 1 'tip'");

    // A missing file names the file.
    modalrt_basis *basis = nullptr;
    ENSURE(modalrt_basis_load("/nonexistent/scene.mrt", &basis) == MODALRT_ERROR_IO && basis == nullptr);
    ENSURE(std::string(modalrt_last_error_message()).find("/nonexistent/scene.mrt") != std::string::npos);
  }

  // FAR_COMPLIANCE (.mrt 1.3): a size that is not a positive multiple of 3 nc, a value that is not
  // finite, and the section in a space without candidates are refused, naming the section and the space.
  void far_field_checked()
  {
    modalrt::LatticeOptions options;
    options.far_rank        = 2;
    const BasisContent good = modalrt::make_lattice_cantilever(options);
    std::string        message;
    ENSURE(try_load(modalrt::write_basis(good), message) == MODALRT_OK);

    BasisContent c = good;
    c.spaces[1].far_compliance.push_back(0.0);
    ensure_rejected(modalrt::write_basis(c), MODALRT_ERROR_FORMAT, "FAR_COMPLIANCE of space 1 'tip': ");
    ensure_rejected(modalrt::write_basis(c), MODALRT_ERROR_FORMAT, "expected a positive multiple of 3 nc");

    c = good;
    c.extra_sections.push_back({mrt::far_compliance, 0, mrt::scene_wide, mrt::f64, 0, {}});
    c.spaces[0].far_compliance.clear();
    ensure_rejected(modalrt::write_basis(c), MODALRT_ERROR_FORMAT, "FAR_COMPLIANCE of space 0 'global': 0 values");

    c = good;
    c.spaces[1].far_compliance[5] = std::nan("");
    ensure_rejected(modalrt::write_basis(c), MODALRT_ERROR_VALUE, "FAR_COMPLIANCE of space 1 'tip': value nan at index 5");

    c                             = worked_example(); // no candidates
    c.spaces[0].far_compliance    = {1e-3, 2e-3, 3e-3};
    ensure_rejected(modalrt::write_basis(c), MODALRT_ERROR_FORMAT, "(the space has no candidates)");
  }

  // Reading from a file gives the same basis as from memory, and names the file in messages.
  void file_round_trip()
  {
    const std::string path = "test_basis_file.mrt";
    BasisContent      c    = modalrt::make_lattice_cantilever();
    ENSURE(modalrt::write_basis_file(path, c));
    modalrt_basis *basis = nullptr;
    ENSURE(modalrt_basis_load(path.c_str(), &basis) == MODALRT_OK);
    modalrt_basis_destroy(basis);
    std::vector<unsigned char> bytes = modalrt::write_basis(c);
    bytes.resize(bytes.size() / 2);
    std::FILE *f = std::fopen(path.c_str(), "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    ENSURE(modalrt_basis_load(path.c_str(), &basis) == MODALRT_ERROR_FORMAT);
    ENSURE(std::string(modalrt_last_error_message()).find(path + ": truncated") != std::string::npos);
    std::remove(path.c_str());
  }
} // namespace

int main()
{
  crc_check_value();
  worked_example_layout();
  round_trip(true);
  round_trip(false);
  newer_minor_version();
  corrupt_files();
  far_field_checked();
  file_round_trip();
  return test::finish("test_basis_file");
}
