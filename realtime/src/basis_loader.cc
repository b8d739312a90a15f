// Reads a .mrt basis file (docs/basis-format.md) and checks everything the kernel relies on, so
// that a tick never meets an index out of range or a number that is not finite. Each check fails
// with a message naming the file and the section.
#include "basis_loader.h"

#include "byte_source.h"
#include "error.h"

#include <mrt/crc32.h>
#include <mrt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <set>
#include <tuple>

namespace modalrt
{
  namespace
  {
    using mrt::crc32;
    using mrt::crc32_update;

    // The format is little-endian; the kernel runs on little-endian machines (x86-64, aarch64).
    bool host_is_little_endian()
    {
      const std::uint32_t one = 1;
      unsigned char       first;
      std::memcpy(&first, &one, 1);
      return first == 1;
    }

    template <typename T>
    T get(const unsigned char *bytes, std::size_t offset)
    {
      T value;
      std::memcpy(&value, bytes + offset, sizeof(T));
      return value;
    }

    template <typename T>
    bool is_finite(T x)
    {
      return std::isfinite(x);
    }

    // ---------------------------------------------------------------------------------------------
    // The reader: header, section table, then the sections in the order of the specification
    // ---------------------------------------------------------------------------------------------
    class BasisReader
    {
    public:
      BasisReader(ByteSource &source, modalrt_basis &basis)
        : source_(source)
        , basis_(basis)
      {}

      void run()
      {
        if (!host_is_little_endian())
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": this reader needs a little-endian machine"));
        read_header();
        read_section_table();
        check_unknown_sections();
        read_scene();
        read_space_names();
        for (std::uint32_t s = 0; s < basis_.space_count(); ++s)
          read_space(s);
        check_max_modes();
        read_transfers();
      }

    private:
      // ----- header ---------------------------------------------------------------------------
      void read_header()
      {
        const std::string &file = basis_.source;
        if (source_.size() < format::header_bytes)
          fail(MODALRT_ERROR_FORMAT,
               cat(file, ": truncated: ", source_.size(), " bytes, shorter than the 64-byte header"));
        unsigned char h[format::header_bytes];
        if (!source_.read(0, h, sizeof h))
          fail(MODALRT_ERROR_IO, cat(file, ": cannot read the header"));

        if (std::memcmp(h, format::magic, 8) != 0)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": bad magic: not a .mrt basis file (expected \"MODALRT\\0\")"));
        basis_.version_major = get<std::uint32_t>(h, format::header::version_major);
        basis_.version_minor = get<std::uint32_t>(h, format::header::version_minor);
        // The major version is checked before the header CRC: another major version may lay out
        // its header differently.
        if (basis_.version_major != format::version_major)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": format version ", basis_.version_major, ".", basis_.version_minor,
                                         " is not supported (this reader reads ", format::version_major, ".x)"));
        const std::uint32_t header_crc = get<std::uint32_t>(h, format::header::header_crc32);
        if (crc32(h, format::header_crc_bytes) != header_crc)
          fail(MODALRT_ERROR_CHECKSUM, cat(file, ": header checksum mismatch (stored 0x", hex(header_crc),
                                           ", computed 0x", hex(crc32(h, format::header_crc_bytes)), ")"));
        if (get<std::uint32_t>(h, format::header::header_bytes) != format::header_bytes)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header_bytes is ", get<std::uint32_t>(h, format::header::header_bytes),
                                         ", expected 64"));

        basis_.file_bytes = get<std::uint64_t>(h, format::header::file_bytes);
        if (source_.size() < basis_.file_bytes)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": truncated: ", source_.size(), " bytes, the header says ",
                                         basis_.file_bytes));
        if (source_.size() > basis_.file_bytes)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": ", source_.size() - basis_.file_bytes,
                                         " bytes after the end the header gives (", basis_.file_bytes, ")"));

        section_count_        = get<std::uint32_t>(h, format::header::section_count);
        space_count_          = get<std::uint32_t>(h, format::header::n_spaces);
        basis_.vertex_count   = get<std::uint32_t>(h, format::header::n_display_vertices);
        basis_.triangle_count = get<std::uint32_t>(h, format::header::n_display_triangles);
        basis_.max_modes      = get<std::uint32_t>(h, format::header::max_modes);
        basis_.max_patch_size = get<std::uint32_t>(h, format::header::max_patch_size);
        basis_.mode_scalar_type = get<std::uint32_t>(h, format::header::mode_scalar_type);
        table_crc_            = get<std::uint32_t>(h, format::header::section_table_crc32);

        if (space_count_ == 0)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header: n_spaces is 0 (the global space is mandatory)"));
        // The spaces are allocated before their sections are read: bound n_spaces by the table
        // first (each space has 4 mandatory sections, the scene 7), so that a corrupt count cannot
        // make the reader allocate gigabytes before it finds the sections missing.
        if (std::uint64_t(space_count_) * 4 + 7 > section_count_)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header: n_spaces is ", space_count_, ", but the ", section_count_,
                                         " sections cannot hold its mandatory sections (4 n_spaces + 7)"));
        if (basis_.vertex_count == 0)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header: n_display_vertices is 0"));
        if (basis_.max_modes == 0 || basis_.max_patch_size == 0)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header: max_modes and max_patch_size must be >= 1"));
        if (basis_.mode_scalar_type != format::f32 && basis_.mode_scalar_type != format::f64)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": header: mode_scalar_type is ", basis_.mode_scalar_type,
                                         ", expected 2 (f32) or 3 (f64)"));
      }

      // ----- section table --------------------------------------------------------------------
      void read_section_table()
      {
        const std::string  &file        = basis_.source;
        const std::uint64_t table_bytes = std::uint64_t(section_count_) * format::table_entry_bytes;
        const std::uint64_t table_end   = format::header_bytes + table_bytes;
        if (table_end > basis_.file_bytes)
          fail(MODALRT_ERROR_FORMAT, cat(file, ": section table (", section_count_,
                                         " entries) runs past the end of the file"));
        std::vector<unsigned char> table(table_bytes);
        if (table_bytes > 0 && !source_.read(format::header_bytes, table.data(), table.size()))
          fail(MODALRT_ERROR_IO, cat(file, ": cannot read the section table"));
        if (crc32(table.data(), table.size()) != table_crc_)
          fail(MODALRT_ERROR_CHECKSUM, cat(file, ": section table checksum mismatch (stored 0x", hex(table_crc_),
                                           ", computed 0x", hex(crc32(table.data(), table.size())), ")"));

        std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> seen;
        for (std::uint32_t k = 0; k < section_count_; ++k)
          {
            const unsigned char *e = table.data() + std::size_t(k) * format::table_entry_bytes;
            SectionRecord        s{get<std::uint32_t>(e, format::entry::kind),
                            get<std::uint32_t>(e, format::entry::space),
                            get<std::uint32_t>(e, format::entry::source_space),
                            get<std::uint32_t>(e, format::entry::scalar_type),
                            get<std::uint64_t>(e, format::entry::offset),
                            get<std::uint64_t>(e, format::entry::count),
                            get<std::uint32_t>(e, format::entry::crc32)};
            check_entry(k, s, table_end);
            if (!seen.insert({s.kind, s.space, s.source_space}).second)
              fail(MODALRT_ERROR_FORMAT, cat(file, ": section table entry ", k, ": ", label(s),
                                             " appears more than once"));
            basis_.sections.push_back(s);
          }
        check_no_overlap();
      }

      // Sections must not share bytes. Each section is copied once into the basis, so this bounds
      // the memory of a load by the file's size (plus about 0.5 kB per declared space): sections
      // pointing at the same bytes, one per space of a crafted table, could otherwise make a 1 MB file
      // take gigabytes (docs/reliability.md).
      void check_no_overlap() const
      {
        std::vector<std::pair<std::uint64_t, std::uint64_t>> spans; // [begin, end) in bytes
        for (const SectionRecord &s : basis_.sections)
          if (s.count > 0)
            spans.emplace_back(s.offset, s.offset + s.count * format::scalar_bytes(s.scalar_type));
        std::sort(spans.begin(), spans.end());
        for (std::size_t k = 1; k < spans.size(); ++k)
          if (spans[k].first < spans[k - 1].second)
            fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": sections overlap: bytes [", spans[k - 1].first, ", ",
                                           spans[k - 1].second, ") and [", spans[k].first, ", ", spans[k].second,
                                           ") (each section must have bytes of its own)"));
      }

      void check_entry(std::uint32_t k, const SectionRecord &s, std::uint64_t table_end)
      {
        const std::string where = cat(basis_.source, ": section table entry ", k, " (", label(s), ")");
        const std::size_t size  = format::scalar_bytes(s.scalar_type);
        if (size == 0)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": unknown scalar type ", s.scalar_type));
        if (s.offset % format::section_alignment != 0)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": offset ", s.offset, " is not a multiple of 64"));
        if (s.offset < table_end)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": offset ", s.offset, " overlaps the header or the section table"));
        // offset > file_bytes first: the subtraction below would wrap around and let any count pass.
        if (s.offset > basis_.file_bytes || s.count > (basis_.file_bytes - s.offset) / size)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": ", s.count, " scalars at offset ", s.offset,
                                         " run past the end of the file (", basis_.file_bytes, " bytes)"));
        if (!format::is_known_kind(s.kind))
          return; // a newer minor version's section: bounds and CRC only
        const std::uint32_t expected =
          s.kind == format::display_modes ? basis_.mode_scalar_type : format::expected_scalar_type(s.kind);
        if (s.scalar_type != expected)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": scalar type ", s.scalar_type, ", expected ", expected,
                                         s.kind == format::display_modes ? " (the header's mode_scalar_type)" : ""));
        if (format::is_scene_wide_kind(s.kind))
          {
            if (s.space != format::scene_wide)
              fail(MODALRT_ERROR_FORMAT, cat(where, ": a scene-wide section must have space 0xFFFFFFFF"));
          }
        else if (s.space >= space_count_)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": space ", s.space, " out of range (n_spaces = ", space_count_, ")"));
        if (s.kind == format::transfer)
          {
            if (s.source_space >= space_count_ || s.source_space == s.space)
              fail(MODALRT_ERROR_FORMAT, cat(where, ": source_space ", s.source_space,
                                             " must be another space below n_spaces = ", space_count_));
          }
        else if (s.source_space != format::scene_wide)
          fail(MODALRT_ERROR_FORMAT, cat(where, ": source_space must be 0xFFFFFFFF"));
      }

      // Sections of a newer minor version are skipped, but a corrupt file is still rejected.
      void check_unknown_sections()
      {
        std::vector<unsigned char> chunk(1 << 16);
        for (const SectionRecord &s : basis_.sections)
          {
            if (format::is_known_kind(s.kind))
              continue;
            std::uint32_t crc  = 0;
            std::uint64_t left = s.count * format::scalar_bytes(s.scalar_type);
            for (std::uint64_t at = s.offset; left > 0;)
              {
                const std::size_t n = std::size_t(std::min<std::uint64_t>(left, chunk.size()));
                if (!source_.read(at, chunk.data(), n))
                  fail(MODALRT_ERROR_IO, cat(basis_.source, ": cannot read section ", label(s)));
                crc = crc32_update(crc, chunk.data(), n);
                at += n;
                left -= n;
              }
            check_crc(s, crc);
          }
      }

      // ----- scene-wide sections --------------------------------------------------------------
      void read_scene()
      {
        const std::uint64_t nv = basis_.vertex_count, nt = basis_.triangle_count;
        basis_.vertices  = read<double>(required(format::display_vertices), 3 * nv, "3 n_display_vertices");
        check_finite(basis_.vertices, format::display_vertices);
        check_coordinates();
        basis_.triangles = read<std::uint32_t>(required(format::display_triangles), 3 * nt, "3 n_display_triangles");
        check_below(basis_.triangles, basis_.vertex_count, format::display_triangles, "vertex index");
        basis_.region = read<std::uint32_t>(required(format::display_region), nv, "n_display_vertices");
        check_below(basis_.region, space_count_, format::display_region, "space");
        read_patches();

        const auto scalars = read<double>(required(format::scene_scalars), format::scene_scalar_count, "14");
        check_finite(scalars, format::scene_scalars);
        std::copy(scalars.begin(), scalars.end(), basis_.scene_scalars.begin());
        if (scalars[0] < 0.0 || scalars[1] < 0.0)
          fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section SCENE_SCALARS: patch radius (", scalars[0],
                                        " m) and mass (", scalars[1], " kg) must be >= 0"));
      }

      // Finite is not enough for the rest positions: what is derived from them at load (the bounding
      // box extent, edge lengths, normals, the snap grid) subtracts and multiplies them, and
      // coordinates near the largest double overflow there to infinity or NaN (the grid's cell-size
      // search then never ended). A bound far beyond any part keeps every derived number finite.
      void check_coordinates() const
      {
        constexpr double max_coordinate = 1e6; // [m]
        for (std::size_t i = 0; i < basis_.vertices.size(); ++i)
          if (std::fabs(basis_.vertices[i]) > max_coordinate)
            fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section DISPLAY_VERTICES: coordinate ", basis_.vertices[i],
                                          " m at index ", i, " is beyond +-", max_coordinate, " m"));
      }

      void read_patches()
      {
        const std::uint32_t nv = basis_.vertex_count;
        basis_.patch_offsets   = read<std::uint32_t>(required(format::patch_offsets), std::uint64_t(nv) + 1, "n_display_vertices + 1");
        const SectionRecord *vertices = required(format::patch_vertices);
        const auto          &offsets  = basis_.patch_offsets;
        if (offsets[0] != 0 || offsets[nv] != vertices->count)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section PATCH_OFFSETS: must start at 0 and end at the ",
                                         vertices->count, " entries of PATCH_VERTICES (starts at ", offsets[0],
                                         ", ends at ", offsets[nv], ")"));
        basis_.patch_vertices = read<std::uint32_t>(vertices, vertices->count, "PATCH_OFFSETS[nv]");
        basis_.patch_weights  = read<double>(required(format::patch_weights), vertices->count, "PATCH_OFFSETS[nv]");
        check_below(basis_.patch_vertices, nv, format::patch_vertices, "vertex index");
        check_finite(basis_.patch_weights, format::patch_weights);

        for (std::uint32_t v = 0; v < nv; ++v)
          {
            const std::uint32_t begin = offsets[v], end = offsets[v + 1];
            // Within PATCH_VERTICES before anything is read: offsets that rise past the end and only
            // fall back later would otherwise be read out of bounds before the fall is seen.
            if (end > offsets[nv])
              fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section PATCH_OFFSETS: the patch of vertex ", v,
                                             " ends at ", end, ", past the ", offsets[nv], " entries of PATCH_VERTICES"));
            if (end < begin || end - begin == 0 || end - begin > basis_.max_patch_size)
              fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section PATCH_OFFSETS: the patch of vertex ", v, " has ",
                                             std::int64_t(end) - std::int64_t(begin),
                                             " entries, expected 1 .. max_patch_size = ", basis_.max_patch_size));
            if (basis_.patch_vertices[begin] != v)
              fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section PATCH_VERTICES: the patch of vertex ", v,
                                             " starts with vertex ", basis_.patch_vertices[begin], ", not with ", v));
            double sum = 0.0;
            for (std::uint32_t k = begin; k < end; ++k)
              {
                if (basis_.patch_weights[k] < 0.0)
                  fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section PATCH_WEIGHTS: negative weight ",
                                                basis_.patch_weights[k], " in the patch of vertex ", v));
                sum += basis_.patch_weights[k];
              }
            if (std::fabs(sum - 1.0) > 1e-9)
              fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section PATCH_WEIGHTS: the weights of the patch of vertex ",
                                            v, " sum to ", sum, ", not 1"));
          }
      }

      // ----- per-space sections ---------------------------------------------------------------
      void read_space_names()
      {
        basis_.spaces.resize(space_count_);
        for (std::uint32_t s = 0; s < space_count_; ++s)
          if (const SectionRecord *name = find(format::space_name, s))
            {
              const auto bytes = read<unsigned char>(name, name->count, "its byte count");
              basis_.spaces[s].name.assign(bytes.begin(), bytes.end());
            }
      }

      void read_space(std::uint32_t s)
      {
        modalrt::ModalSpace &space = basis_.spaces[s];
        const auto           info  = read<std::uint32_t>(required(format::space_info, s), 4, "4");
        space.mode_count           = info[0];
        space.candidate_count      = info[1];
        space.validation_count     = info[2];
        space.cross_count          = info[3];
        const std::uint64_t r = space.mode_count, nc = space.candidate_count, nv = basis_.vertex_count;
        if (r == 0 || r > basis_.max_modes)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section SPACE_INFO of ", space_label(s), ": r = ", r,
                                         ", expected 1 .. max_modes = ", basis_.max_modes));
        if (space.cross_count != 0 && space.cross_count != nc)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section SPACE_INFO of ", space_label(s), ": n_cross = ",
                                         space.cross_count, ", expected 0 or nc = ", nc));

        read_spectrum(s, space);
        const SectionRecord *modes = required(format::display_modes, s);
        if (basis_.float64_modes())
          {
            space.display_modes_f64 = read<double>(modes, 3 * nv * r, "3 n_display_vertices r");
            check_finite(space.display_modes_f64, format::display_modes, s);
          }
        else
          {
            space.display_modes_f32 = read<float>(modes, 3 * nv * r, "3 n_display_vertices r");
            check_finite(space.display_modes_f32, format::display_modes, s);
          }
        read_candidates(s, space);
        // PARTICIPATION is optional whatever r is (it is not in the specification's mandatory
        // list; without it the frame's acceleration does not drive the modes), so a missing one
        // is "not stored", not a count mismatch.
        if (const SectionRecord *participation = find(format::participation, s))
          space.participation = read<double>(participation, 6 * r, "6 r");
        check_finite(space.participation, format::participation, s);
        read_validation(s, space);
      }

      // The header's max_modes sizes every buffer of a kernel and of a snapshot, so it must be what
      // the specification says, the largest r, and not merely an upper bound: a corrupt value with
      // recomputed checksums would otherwise pass and make modalrt_kernel_create (and the
      // self-check) allocate gigabytes.
      void check_max_modes() const
      {
        std::uint32_t largest = 0;
        for (const modalrt::ModalSpace &space : basis_.spaces)
          largest = std::max(largest, space.mode_count);
        if (basis_.max_modes != largest)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": header: max_modes is ", basis_.max_modes,
                                         ", but the largest r over the spaces is ", largest));
      }

      void read_spectrum(std::uint32_t s, modalrt::ModalSpace &space)
      {
        space.eigenvalues = read<double>(required(format::eigenvalues, s), space.mode_count, "r");
        check_finite(space.eigenvalues, format::eigenvalues, s);
        for (std::uint32_t i = 0; i < space.mode_count; ++i)
          {
            if (space.eigenvalues[i] < 0.0)
              fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section EIGENVALUES of ", space_label(s), ": lambda_", i,
                                            " = ", space.eigenvalues[i], " is negative"));
            if (i > 0 && space.eigenvalues[i] < space.eigenvalues[i - 1])
              fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section EIGENVALUES of ", space_label(s),
                                            ": not ascending at index ", i));
          }
        space.damping_ratios = read<double>(required(format::damping_ratios, s), space.mode_count, "r");
        check_finite(space.damping_ratios, format::damping_ratios, s);
        for (std::uint32_t i = 0; i < space.mode_count; ++i)
          if (space.damping_ratios[i] < 0.0)
            fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section DAMPING_RATIOS of ", space_label(s), ": zeta_", i,
                                          " = ", space.damping_ratios[i], " is negative"));
      }

      void read_candidates(std::uint32_t s, modalrt::ModalSpace &space)
      {
        const std::uint64_t r = space.mode_count, nc = space.candidate_count;
        space.candidates = read_optional<std::uint32_t>(format::candidate_vertices, s, nc, "nc");
        check_below(space.candidates, basis_.vertex_count, format::candidate_vertices, "vertex index", s);
        for (std::size_t k = 1; k < space.candidates.size(); ++k)
          if (space.candidates[k] <= space.candidates[k - 1])
            fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section CANDIDATE_VERTICES of ", space_label(s),
                                           ": not strictly ascending at index ", k));
        space.candidate_modes      = read_optional<double>(format::candidate_modes, s, 3 * nc * r, "3 nc r");
        space.candidate_compliance = read_optional<double>(format::candidate_compliance, s, 9 * nc, "9 nc");
        check_finite(space.candidate_modes, format::candidate_modes, s);
        check_finite(space.candidate_compliance, format::candidate_compliance, s);
        if (space.cross_count > 0)
          read_dense_cross(s, space);
        else if (find(format::cross_offsets, s) != nullptr)
          read_sparse_cross(s, space);
        read_far_field(s, space);
        space.felt_stiffness = read_optional<double>(format::felt_stiffness, s,
                                                     find(format::felt_stiffness, s) ? basis_.vertex_count : 0, "nv");
        check_finite(space.felt_stiffness, format::felt_stiffness, s);
        read_validity(s, space);
      }

      // Version 1.2's validity map: 3 nv forces, each finite and >= 0 (1e30, "not reached", is beyond
      // check_finite's bound of absurdity, so it has its own check), the positive ones of a vertex
      // non-decreasing (F1 <= F5 <= F10: a larger departure is reached at a larger force).
      void read_validity(std::uint32_t s, modalrt::ModalSpace &space)
      {
        space.validity_force = read_optional<double>(format::validity_force, s,
                                                     find(format::validity_force, s) ? 3 * std::uint64_t(basis_.vertex_count) : 0,
                                                     "3 nv");
        const std::string where = cat(basis_.source, ": section VALIDITY_FORCE of ", space_label(s));
        for (std::size_t i = 0; i < space.validity_force.size(); ++i)
          if (!std::isfinite(space.validity_force[i]) || space.validity_force[i] < 0.0)
            fail(MODALRT_ERROR_VALUE, cat(where, ": value ", space.validity_force[i], " N at index ", i, " (vertex ", i / 3,
                                          ") is ", std::isfinite(space.validity_force[i]) ? "negative" : "not finite",
                                          " (expected a force >= 0: 0 no value, 1e30 not reached)"));
        for (std::size_t v = 0; 3 * v < space.validity_force.size(); ++v)
          {
            const double *F = &space.validity_force[3 * v];
            for (int a = 0; a < 3; ++a)
              for (int b = a + 1; b < 3; ++b)
                if (F[a] > 0.0 && F[b] > 0.0 && F[b] < F[a])
                  fail(MODALRT_ERROR_VALUE, cat(where, ": vertex ", v, ": F", a == 0 ? 1 : 5, " = ", F[a], " N > F",
                                                b == 1 ? 5 : 10, " = ", F[b],
                                                " N (the forces of 1, 5, 10 % must not decrease)"));
          }
      }

      // Version 1.3's far field: candidate a's 3 x k factor Z_a, k = count / (3 nc) >= 1 (so the space
      // needs candidates), every value finite and within the bound on absurd magnitudes.
      void read_far_field(std::uint32_t s, modalrt::ModalSpace &space)
      {
        const SectionRecord *far = find(format::far_compliance, s);
        if (!far)
          return;
        const std::uint64_t rows = 3 * std::uint64_t(space.candidate_count);
        if (rows == 0 || far->count == 0 || far->count % rows != 0)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section FAR_COMPLIANCE of ", space_label(s), ": ", far->count,
                                         " values, expected a positive multiple of 3 nc = ", rows,
                                         rows == 0 ? " (the space has no candidates)" : " (3 nc k, k the rank)"));
        space.far_compliance = read<double>(far, far->count, "3 nc k");
        check_finite(space.far_compliance, format::far_compliance, s);
        space.far_rank = std::uint32_t(far->count / rows);
      }

      // Version 1.0's dense CROSS_COMPLIANCE, kept as rows in which every other candidate is a
      // neighbour (one form for the kernel).
      void read_dense_cross(std::uint32_t s, modalrt::ModalSpace &space)
      {
        const std::uint64_t nc = space.candidate_count, n3 = 3 * nc;
        const auto dense = read_optional<double>(format::cross_compliance, s, n3 * n3, "(3 n_cross)^2");
        check_finite(dense, format::cross_compliance, s);
        check_cross_diagonal(s, space, dense);
        space.cross_offsets.assign(nc + 1, 0);
        space.cross_neighbours.assign(nc * (nc - 1), 0);
        space.cross_blocks.assign(9 * nc * (nc - 1), 0.0);
        std::size_t k = 0;
        for (std::uint64_t a = 0; a < nc; ++a)
          {
            for (std::uint64_t b = 0; b < nc; ++b)
              if (b != a)
                {
                  space.cross_neighbours[k] = std::uint32_t(b);
                  for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                      space.cross_blocks[9 * k + 3 * i + j] = dense[(3 * a + i) * n3 + 3 * b + j];
                  ++k;
                }
            space.cross_offsets[a + 1] = std::uint32_t(k);
          }
      }

      // Version 1.1's compressed rows: nc + 1 offsets from 0, ascending; in each row, neighbours
      // strictly ascending, below nc and other than the row's own candidate.
      void read_sparse_cross(std::uint32_t s, modalrt::ModalSpace &space)
      {
        const std::uint64_t nc = space.candidate_count;
        space.cross_offsets    = read_optional<std::uint32_t>(format::cross_offsets, s, nc + 1, "nc + 1");
        const std::uint64_t n  = space.cross_offsets.empty() ? 0 : space.cross_offsets[nc];
        for (std::uint64_t a = 0; a < nc; ++a)
          if (space.cross_offsets[a + 1] < space.cross_offsets[a] || space.cross_offsets[0] != 0)
            fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section CROSS_OFFSETS of ", space_label(s),
                                           ": not ascending from 0 at candidate ", a));
        space.cross_neighbours = read_optional<std::uint32_t>(format::cross_neighbours, s, n, "CROSS_OFFSETS[nc]");
        space.cross_blocks     = read_optional<double>(format::cross_blocks, s, 9 * n, "9 CROSS_OFFSETS[nc]");
        check_finite(space.cross_blocks, format::cross_blocks, s);
        for (std::uint64_t a = 0; a < nc; ++a)
          for (std::uint64_t k = space.cross_offsets[a]; k < space.cross_offsets[a + 1]; ++k)
            {
              const std::uint32_t b = space.cross_neighbours[k];
              if (b >= nc || b == a || (k > space.cross_offsets[a] && b <= space.cross_neighbours[k - 1]))
                fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section CROSS_NEIGHBOURS of ", space_label(s),
                                               ": entry ", k, " (candidate ", b, " in the row of candidate ", a,
                                               ") is not a strictly ascending index below nc other than ", a));
            }
        space.cross_count = std::uint32_t(nc);
      }

      // The specification says the diagonal blocks of CROSS_COMPLIANCE equal CANDIDATE_COMPLIANCE;
      // the kernel uses the latter for a HIP alone, so a mismatch would make the felt stiffness
      // depend on whether a second HIP touches elsewhere.
      void check_cross_diagonal(std::uint32_t s, const modalrt::ModalSpace &space, const modalrt::Vector<double> &dense)
      {
        const std::size_t n3 = 3 * std::size_t(space.cross_count);
        for (std::size_t a = 0; a < space.cross_count; ++a)
          {
            double scale = 1e-300, worst = 0.0;
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j)
                {
                  const double c = space.candidate_compliance[9 * a + 3 * i + j];
                  const double x = dense[(3 * a + i) * n3 + 3 * a + j];
                  scale          = std::max(scale, std::fabs(c));
                  worst          = std::max(worst, std::fabs(c - x));
                }
            if (worst > 1e-8 * scale)
              fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section CROSS_COMPLIANCE of ", space_label(s),
                                            ": diagonal block of candidate ", a,
                                            " differs from CANDIDATE_COMPLIANCE by ", worst / scale, " (relative)"));
          }
      }

      void read_validation(std::uint32_t s, modalrt::ModalSpace &space)
      {
        const std::uint64_t nval = space.validation_count;
        space.validation_cases   = read_optional<std::uint32_t>(format::validation_cases, s, 2 * nval, "2 nval");
        space.validation_response = read_optional<double>(format::validation_response, s, 3 * nval, "3 nval");
        check_finite(space.validation_response, format::validation_response, s);
        for (std::uint64_t c = 0; c < nval; ++c)
          if (space.validation_cases[2 * c] >= basis_.vertex_count || space.validation_cases[2 * c + 1] > 2)
            fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section VALIDATION_CASES of ", space_label(s), ": case ", c,
                                           " has vertex ", space.validation_cases[2 * c], " (n_display_vertices = ",
                                           basis_.vertex_count, ") and direction ", space.validation_cases[2 * c + 1],
                                           " (0, 1 or 2)"));
      }

      void read_transfers()
      {
        // Only the pairs the file holds (a square table of n_spaces^2 entries was the crafted-file
        // memory bound of docs/reliability.md).
        basis_.transfers.clear();
        for (const SectionRecord &s : basis_.sections)
          {
            if (s.kind != format::transfer)
              continue;
            const std::uint64_t rows = basis_.spaces[s.space].mode_count;
            const std::uint64_t cols = basis_.spaces[s.source_space].mode_count;
            auto                t    = read<double>(&s, rows * cols, "r_k r_j");
            check_finite(t, format::transfer, s.space);
            basis_.transfers.push_back({s.space, s.source_space, std::move(t)});
          }
        std::sort(basis_.transfers.begin(), basis_.transfers.end(), [](const auto &a, const auto &b) {
          return a.to < b.to || (a.to == b.to && a.from < b.from);
        });
      }

      // ----- helpers --------------------------------------------------------------------------
      const SectionRecord *find(std::uint32_t kind, std::uint32_t space = format::scene_wide) const
      {
        for (const SectionRecord &s : basis_.sections)
          if (s.kind == kind && s.space == space && s.source_space == format::scene_wide)
            return &s;
        return nullptr;
      }

      const SectionRecord *required(std::uint32_t kind, std::uint32_t space = format::scene_wide) const
      {
        const SectionRecord *s = find(kind, space);
        if (!s)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": mandatory section ", format::kind_name(kind),
                                         space == format::scene_wide ? std::string() : " of " + space_label(space),
                                         " is missing"));
        return s;
      }

      // Reads a section of known count into a typed array, checking count and CRC.
      template <typename T>
      modalrt::Vector<T> read(const SectionRecord *s, std::uint64_t expected_count, const char *count_formula)
      {
        if (s->count != expected_count)
          fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section ", label(*s), ": ", s->count,
                                         " scalars, expected ", count_formula, " = ", expected_count));
        modalrt::Vector<T> values(std::size_t(s->count));
        const std::size_t bytes = values.size() * sizeof(T);
        if (bytes > 0 && !source_.read(s->offset, values.data(), bytes))
          fail(MODALRT_ERROR_IO, cat(basis_.source, ": cannot read section ", label(*s)));
        check_crc(*s, crc32(values.data(), bytes));
        return values;
      }

      // A missing optional section reads as count 0.
      template <typename T>
      modalrt::Vector<T> read_optional(std::uint32_t kind, std::uint32_t space, std::uint64_t expected_count,
                                   const char *count_formula)
      {
        const SectionRecord *s = find(kind, space);
        if (!s)
          {
            if (expected_count != 0)
              fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section ", format::kind_name(kind), " of ",
                                             space_label(space), " is missing (", count_formula, " = ",
                                             expected_count, " from SPACE_INFO)"));
            return {};
          }
        return read<T>(s, expected_count, count_formula);
      }

      void check_crc(const SectionRecord &s, std::uint32_t computed) const
      {
        if (computed != s.crc32)
          fail(MODALRT_ERROR_CHECKSUM, cat(basis_.source, ": section ", label(s), ": checksum mismatch (stored 0x",
                                           hex(s.crc32), ", computed 0x", hex(computed), ")"));
      }

      template <typename T>
      void check_finite(const modalrt::Vector<T> &values, std::uint32_t kind, std::uint32_t space = format::scene_wide) const
      {
        // Finite is not enough: a value beyond max_magnitude is absurd for any part (eigenvalues up to
        // omega = 1e10 rad/s, mode entries of parts down to 1e-40 kg), and products of a few such
        // values stay finite in the kernel.
        constexpr double max_magnitude = 1e20;
        for (std::size_t i = 0; i < values.size(); ++i)
          if (!is_finite(values[i]) || std::fabs(double(values[i])) > max_magnitude)
            fail(MODALRT_ERROR_VALUE, cat(basis_.source, ": section ", format::kind_name(kind),
                                          space == format::scene_wide ? std::string() : " of " + space_label(space),
                                          ": value ", double(values[i]), " at index ", i,
                                          is_finite(values[i]) ? " is beyond +-1e20 (absurd)" : " is not finite"));
      }

      void check_below(const modalrt::Vector<std::uint32_t> &values, std::uint32_t bound, std::uint32_t kind,
                       const char *what, std::uint32_t space = format::scene_wide) const
      {
        for (std::size_t i = 0; i < values.size(); ++i)
          if (values[i] >= bound)
            fail(MODALRT_ERROR_FORMAT, cat(basis_.source, ": section ", format::kind_name(kind),
                                           space == format::scene_wide ? std::string() : " of " + space_label(space),
                                           ": ", what, " ", values[i], " at index ", i, " is out of range (< ", bound,
                                           " expected)"));
      }

      std::string space_label(std::uint32_t s) const
      {
        std::string text = cat("space ", s);
        if (s < basis_.spaces.size() && !basis_.spaces[s].name.empty())
          text += " '" + basis_.spaces[s].name + "'";
        return text;
      }

      std::string label(const SectionRecord &s) const
      {
        std::string text = cat(format::kind_name(s.kind));
        if (!format::is_known_kind(s.kind))
          text += cat(" kind ", s.kind);
        if (s.space != format::scene_wide)
          text += " of " + space_label(s.space);
        if (s.kind == format::transfer)
          text += cat(" from space ", s.source_space);
        return text;
      }

      static std::string hex(std::uint32_t x)
      {
        char text[16];
        std::snprintf(text, sizeof text, "%08X", x);
        return text;
      }

      ByteSource    &source_;
      modalrt_basis &basis_;
      std::uint32_t  section_count_ = 0, space_count_ = 0, table_crc_ = 0;
    };
  } // namespace

  std::unique_ptr<modalrt_basis> load_basis_file(const std::string &path)
  {
    auto basis    = std::make_unique<modalrt_basis>();
    basis->source = path;
    FileSource source(path);
    BasisReader(source, *basis).run();
    finish_basis(*basis);
    return basis;
  }

  std::unique_ptr<modalrt_basis> load_basis_memory(const void *bytes, std::size_t size)
  {
    auto basis    = std::make_unique<modalrt_basis>();
    basis->source = "<memory>";
    MemorySource source(bytes, size);
    BasisReader(source, *basis).run();
    finish_basis(*basis);
    return basis;
  }
} // namespace modalrt
