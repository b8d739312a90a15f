// Writes the seed corpus of fuzz_basis_loader (tests/fuzz/corpus/basis/): small valid .mrt files
// made with the kernel's synthetic scenes (tests/realtime/support) and the .mrt writer (mrt/), and
// corrupted variants that each stop at a different check of the reader. Seeds are kept small (a few kB) because libFuzzer mutates faster and
// further on small inputs, and because the corpus is committed.
//
//   make_seed_corpus DIR      (scripts/test-kernel-checks does not run it: the corpus is committed;
//                              run it again only when the format or the synthetic scenes change)
#include "seed_file.h"
#include "synthetic_scene.h"

#include <mrt/format.h>
#include <mrt/writer.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace
{
  using Bytes = std::vector<unsigned char>;
  using seed::save;
  namespace format = mrt;

  template <typename T>
  T get(const Bytes &bytes, std::size_t offset)
  {
    T value;
    std::memcpy(&value, bytes.data() + offset, sizeof(T));
    return value;
  }

  template <typename T>
  void put(Bytes &bytes, std::size_t offset, T value)
  {
    std::memcpy(bytes.data() + offset, &value, sizeof(T));
  }

  // Byte offset of the table entry of section (kind, space) in a file this program just wrote.
  std::size_t table_entry(const Bytes &bytes, std::uint32_t kind, std::uint32_t space = format::scene_wide)
  {
    const std::uint32_t n = get<std::uint32_t>(bytes, format::header::section_count);
    for (std::uint32_t k = 0; k < n; ++k)
      {
        const std::size_t entry = format::header_bytes + format::table_entry_bytes * k;
        if (get<std::uint32_t>(bytes, entry + format::entry::kind) == kind &&
            get<std::uint32_t>(bytes, entry + format::entry::space) == space)
          return entry;
      }
    std::fprintf(stderr, "make_seed_corpus: section kind %u of space %u not found\n", kind, space);
    std::exit(1);
  }

  // Byte offset of the data of section (kind, space).
  std::size_t section_offset(const Bytes &bytes, std::uint32_t kind, std::uint32_t space = format::scene_wide)
  {
    return std::size_t(get<std::uint64_t>(bytes, table_entry(bytes, kind, space) + format::entry::offset));
  }

  // The smallest lattice that still has two spaces, candidates, validation cases and transfers.
  modalrt::LatticeOptions small_lattice()
  {
    modalrt::LatticeOptions o;
    o.nx = 5;
    o.ny = 2;
    o.nz = 2;
    o.modes               = {4, 6};
    o.damping             = {0.02, 0.05};
    o.candidate_stride    = 2;
    o.validation_vertices = 1;
    return o;
  }
} // namespace

int main(int argc, char **argv)
{
  if (argc != 2)
    {
      std::fprintf(stderr, "usage: make_seed_corpus DIR\n");
      return 2;
    }
  const std::string dir = argv[1];
  bool              ok  = true;

  // ----- valid files: each feature of the format at least once ------------------------------------
  const Bytes two_spaces = mrt::write_basis(modalrt::make_lattice_cantilever(small_lattice()));
  ok &= save(dir, "lattice_two_spaces_f64.mrt", two_spaces);

  modalrt::LatticeOptions patches = small_lattice();
  patches.float64_modes = false; // f32 display modes
  patches.patch_radius  = 0.06;  // patches of several vertices (spacing 0.05 m along x)
  patches.cross         = false;
  patches.transfers     = false;
  patches.participation = false;
  ok &= save(dir, "lattice_patches_f32.mrt", mrt::write_basis(modalrt::make_lattice_cantilever(patches)));

  modalrt::LatticeOptions one_space = small_lattice();
  one_space.modes   = {5};
  one_space.damping = {0.03};
  ok &= save(dir, "lattice_one_space.mrt", mrt::write_basis(modalrt::make_lattice_cantilever(one_space)));

  modalrt::PlateOptions plate;
  plate.nx         = 6;
  plate.ny         = 5;
  plate.modes      = 4;
  plate.spaces     = 2;
  plate.candidates = 3;
  ok &= save(dir, "plate_two_spaces_f32.mrt", mrt::write_basis(modalrt::make_analytic_plate(plate)));

  // A newer minor version with a section kind this reader does not know (skipped after its CRC).
  mrt::BasisContent newer = modalrt::make_lattice_cantilever(one_space);
  newer.version_minor         = 1;
  newer.extra_sections.push_back({99, format::scene_wide, format::scene_wide, format::u8, 5, {1, 2, 3, 4, 5}});
  ok &= save(dir, "newer_minor_extra_section.mrt", mrt::write_basis(newer));

  // Version 1.2's validity map (VALIDITY_FORCE) in both spaces, with 1e30 (not reached) entries.
  modalrt::LatticeOptions validity = small_lattice();
  validity.validity_force          = true;
  const Bytes with_validity        = mrt::write_basis(modalrt::make_lattice_cantilever(validity));
  ok &= save(dir, "lattice_validity_force.mrt", with_validity);

  // Version 1.3's far field (FAR_COMPLIANCE) in both spaces, rank 3.
  modalrt::LatticeOptions far_field = small_lattice();
  far_field.far_rank          = 3;
  ok &= save(dir, "lattice_far_compliance.mrt", mrt::write_basis(modalrt::make_lattice_cantilever(far_field)));

  // ----- corrupted variants of the two-space file --------------------------------------------------
  ok &= save(dir, "corrupt_header_only.mrt", Bytes(two_spaces.begin(), two_spaces.begin() + format::header_bytes));
  ok &= save(dir, "corrupt_truncated.mrt", Bytes(two_spaces.begin(), two_spaces.begin() + two_spaces.size() * 3 / 5));

  Bytes magic = two_spaces;
  magic[0]    = 'X';
  ok &= save(dir, "corrupt_bad_magic.mrt", magic);

  // A flipped bit in the modes, checksum left stale: refused by the section CRC.
  Bytes stale = two_spaces;
  stale[section_offset(stale, format::display_modes, 0) + 5] ^= 0x10;
  ok &= save(dir, "corrupt_section_crc.mrt", stale);

  // The next ones have their checksums recomputed, so they reach the check behind the CRC.
  Bytes triangle = two_spaces;
  put<std::uint32_t>(triangle, section_offset(triangle, format::display_triangles) + 4,
                     get<std::uint32_t>(triangle, format::header::n_display_vertices)); // one past the last vertex
  mrt::refresh_checksums(triangle);
  ok &= save(dir, "corrupt_triangle_index.mrt", triangle);

  Bytes nan = two_spaces;
  put<double>(nan, section_offset(nan, format::eigenvalues, 1) + 8, std::numeric_limits<double>::quiet_NaN());
  mrt::refresh_checksums(nan);
  ok &= save(dir, "corrupt_nan_eigenvalue.mrt", nan);

  Bytes offsets = two_spaces;
  put<std::uint32_t>(offsets, section_offset(offsets, format::patch_offsets) + 8, 0); // patch of vertex 1 ends before it starts
  mrt::refresh_checksums(offsets);
  ok &= save(dir, "corrupt_patch_offsets.mrt", offsets);

  // The patch of vertex 0 running past the end of PATCH_VERTICES (the offsets fall back only at
  // vertex 1), with a max_patch_size that allows it: the reader read its weights out of bounds.
  Bytes overrun = two_spaces;
  put<std::uint32_t>(overrun, section_offset(overrun, format::patch_offsets) + 4, 40);
  put<std::uint32_t>(overrun, format::header::max_patch_size, 64);
  mrt::refresh_checksums(overrun);
  ok &= save(dir, "corrupt_patch_overrun.mrt", overrun);

  // Finite but astronomically far vertices: their differences overflow in what the loader derives.
  Bytes far = two_spaces;
  put<double>(far, section_offset(far, format::display_vertices), -1e308);
  put<double>(far, section_offset(far, format::display_vertices) + 24, 1e308);
  mrt::refresh_checksums(far);
  ok &= save(dir, "corrupt_far_vertices.mrt", far);

  // A capacity far above every space's r: the kernel would size its buffers by it.
  Bytes capacity = two_spaces;
  put<std::uint32_t>(capacity, format::header::max_modes, 0x40000000u);
  mrt::refresh_checksums(capacity);
  ok &= save(dir, "corrupt_max_modes.mrt", capacity);

  // A space count the section table cannot hold (the reader sized its spaces by it first).
  Bytes spaces = two_spaces;
  put<std::uint32_t>(spaces, format::header::n_spaces, 0x10000000u);
  mrt::refresh_checksums(spaces);
  ok &= save(dir, "corrupt_n_spaces.mrt", spaces);

  // A section whose offset lies beyond the end of the file, with a count of about 10^12 bytes (the
  // bounds check wrapped around and the reader allocated the count before reading).
  Bytes beyond             = two_spaces;
  const std::size_t name   = table_entry(beyond, format::space_name, 0);
  put<std::uint64_t>(beyond, name + format::entry::offset, (beyond.size() / 64 + 1000) * 64);
  put<std::uint64_t>(beyond, name + format::entry::count, 0xFFFFFFFFFAull);
  mrt::refresh_checksums(beyond);
  ok &= save(dir, "corrupt_section_offset.mrt", beyond);

  // A validity map whose F5 falls below F1 at a vertex (the positive forces of a vertex must not
  // decrease), checksums recomputed.
  Bytes decreasing        = with_validity;
  const std::size_t first = section_offset(decreasing, format::validity_force, 1);
  const std::uint32_t nv  = get<std::uint32_t>(decreasing, format::header::n_display_vertices);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (get<double>(decreasing, first + 24 * v) > 0.0)
      {
        put<double>(decreasing, first + 24 * v + 8, 0.5 * get<double>(decreasing, first + 24 * v));
        break;
      }
  mrt::refresh_checksums(decreasing);
  ok &= save(dir, "corrupt_validity_decreasing.mrt", decreasing);

  return ok ? 0 : 1;
}
