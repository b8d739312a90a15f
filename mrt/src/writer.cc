// The .mrt writer (writer.h): the content of a basis laid out as docs/basis-format.md specifies.
#include <mrt/crc32.h>
#include <mrt/format.h>
#include <mrt/writer.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace mrt
{
  namespace
  {
    // One section of the file: its table entry (without offset and CRC) and its bytes.
    struct Section
    {
      std::uint32_t              kind, space, source_space, scalar_type;
      std::uint64_t              count;
      std::vector<unsigned char> bytes;
    };

    template <typename T>
    Section make(std::uint32_t kind, std::uint32_t space, std::uint32_t type, const std::vector<T> &values,
                 std::uint32_t source_space = scene_wide)
    {
      Section s{kind, space, source_space, type, values.size(), std::vector<unsigned char>(values.size() * sizeof(T))};
      if (!values.empty())
        std::memcpy(s.bytes.data(), values.data(), s.bytes.size());
      return s;
    }

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

    std::uint64_t align64(std::uint64_t x) { return (x + 63) / 64 * 64; }

    void add_space_sections(std::vector<Section> &out, const BasisContent &c, std::uint32_t s)
    {
      const BasisSpaceContent &sp = c.spaces[s];
      const std::uint32_t      r = std::uint32_t(sp.eigenvalues.size()), nc = std::uint32_t(sp.candidates.size());
      const std::uint32_t      n_cross = sp.cross_compliance.empty() ? 0 : nc;
      const std::uint32_t      nval    = std::uint32_t(sp.validation_cases.size() / 2);
      out.push_back(make(space_info, s, u32, std::vector<std::uint32_t>{r, nc, nval, n_cross}));
      out.push_back(make(space_name, s, u8, std::vector<unsigned char>(sp.name.begin(), sp.name.end())));
      out.push_back(make(eigenvalues, s, f64, sp.eigenvalues));
      out.push_back(make(damping_ratios, s, f64, sp.damping_ratios));
      if (c.float64_modes)
        out.push_back(make(display_modes, s, f64, sp.display_modes));
      else
        out.push_back(make(display_modes, s, f32,
                           std::vector<float>(sp.display_modes.begin(), sp.display_modes.end())));
      if (nc > 0)
        {
          out.push_back(make(candidate_vertices, s, u32, sp.candidates));
          out.push_back(make(candidate_modes, s, f64, sp.candidate_modes));
          out.push_back(make(candidate_compliance, s, f64, sp.candidate_compliance));
          if (n_cross > 0)
            out.push_back(make(cross_compliance, s, f64, sp.cross_compliance));
          if (!sp.cross_offsets.empty())
            {
              out.push_back(make(cross_offsets, s, u32, sp.cross_offsets));
              out.push_back(make(cross_neighbours, s, u32, sp.cross_neighbours));
              out.push_back(make(cross_blocks, s, f64, sp.cross_blocks));
            }
        }
      if (!sp.far_compliance.empty()) // written as given: a reader refuses it without candidates
        out.push_back(make(far_compliance, s, f64, sp.far_compliance));
      if (!sp.participation.empty())
        out.push_back(make(participation, s, f64, sp.participation));
      if (nval > 0)
        {
          out.push_back(make(validation_cases, s, u32, sp.validation_cases));
          out.push_back(make(validation_response, s, f64, sp.validation_response));
        }
      if (!sp.felt_stiffness.empty())
        out.push_back(make(felt_stiffness, s, f64, sp.felt_stiffness));
      if (!sp.validity_force.empty())
        out.push_back(make(validity_force, s, f64, sp.validity_force));
    }

    std::vector<double> packed_scene_scalars(const SceneScalars &named)
    {
      std::vector<double> packed(scene_scalar::count, 0.);
      packed[scene_scalar::patch_radius] = named.patch_radius;
      packed[scene_scalar::mass]         = named.mass;
      std::copy(named.centre_of_mass.begin(), named.centre_of_mass.end(), packed.begin() + scene_scalar::centre_of_mass);
      std::copy(named.inertia.begin(), named.inertia.end(), packed.begin() + scene_scalar::inertia);
      return packed;
    }

    std::vector<Section> sections_of(const BasisContent &c)
    {
      std::vector<Section> out;
      out.push_back(make(display_vertices, scene_wide, f64, c.vertices));
      out.push_back(make(display_triangles, scene_wide, u32, c.triangles));
      out.push_back(make(display_region, scene_wide, u32, c.region));
      out.push_back(make(patch_offsets, scene_wide, u32, c.patch_offsets));
      out.push_back(make(patch_vertices, scene_wide, u32, c.patch_vertices));
      out.push_back(make(patch_weights, scene_wide, f64, c.patch_weights));
      out.push_back(make(scene_scalars, scene_wide, f64, packed_scene_scalars(c.scene_scalars)));
      for (std::uint32_t s = 0; s < c.spaces.size(); ++s)
        add_space_sections(out, c, s);
      for (const BasisTransferContent &t : c.transfers)
        out.push_back(make(transfer, t.to, f64, t.values, t.from));
      for (const ExtraSection &e : c.extra_sections)
        out.push_back(Section{e.kind, e.space, e.source_space, e.scalar_type, e.count, e.bytes});
      return out;
    }

    std::uint32_t max_patch_size(const BasisContent &c)
    {
      std::uint32_t m = 0;
      for (std::size_t v = 0; v + 1 < c.patch_offsets.size(); ++v)
        m = std::max(m, c.patch_offsets[v + 1] - c.patch_offsets[v]);
      return m;
    }
  } // namespace

  std::vector<unsigned char> write_basis(const BasisContent &c)
  {
    const std::vector<Section> sections = sections_of(c);
    std::vector<std::uint64_t> offsets;
    std::uint64_t              end = header_bytes + table_entry_bytes * sections.size();
    for (const Section &s : sections)
      {
        offsets.push_back(align64(end));
        end = offsets.back() + s.bytes.size();
      }
    std::vector<unsigned char> bytes(end, 0);
    for (std::size_t k = 0; k < sections.size(); ++k)
      {
        const Section    &s     = sections[k];
        const std::size_t row = header_bytes + table_entry_bytes * k;
        put<std::uint32_t>(bytes, row + entry::kind, s.kind);
        put<std::uint32_t>(bytes, row + entry::space, s.space);
        put<std::uint32_t>(bytes, row + entry::source_space, s.source_space);
        put<std::uint32_t>(bytes, row + entry::scalar_type, s.scalar_type);
        put<std::uint64_t>(bytes, row + entry::offset, offsets[k]);
        put<std::uint64_t>(bytes, row + entry::count, s.count);
        put<std::uint32_t>(bytes, row + entry::crc32, crc32(s.bytes.data(), s.bytes.size()));
        if (!s.bytes.empty())
          std::memcpy(bytes.data() + offsets[k], s.bytes.data(), s.bytes.size());
      }

    std::uint32_t max_modes = 0;
    for (const BasisSpaceContent &s : c.spaces)
      max_modes = std::max(max_modes, std::uint32_t(s.eigenvalues.size()));
    std::memcpy(bytes.data(), magic, 8);
    put<std::uint32_t>(bytes, header::version_major, version_major);
    put<std::uint32_t>(bytes, header::version_minor, c.version_minor);
    put<std::uint32_t>(bytes, header::header_bytes, header_bytes);
    put<std::uint32_t>(bytes, header::section_count, std::uint32_t(sections.size()));
    put<std::uint64_t>(bytes, header::file_bytes, end);
    put<std::uint32_t>(bytes, header::n_spaces, std::uint32_t(c.spaces.size()));
    put<std::uint32_t>(bytes, header::n_display_vertices, c.vertex_count());
    put<std::uint32_t>(bytes, header::n_display_triangles, std::uint32_t(c.triangles.size() / 3));
    put<std::uint32_t>(bytes, header::max_modes, max_modes);
    put<std::uint32_t>(bytes, header::max_patch_size, max_patch_size(c));
    put<std::uint32_t>(bytes, header::mode_scalar_type, c.float64_modes ? f64 : f32);
    refresh_checksums(bytes);
    return bytes;
  }

  void refresh_checksums(std::vector<unsigned char> &bytes)
  {
    const std::size_t size = bytes.size();
    if (size < header_bytes)
      return;
    const std::uint64_t declared = get<std::uint32_t>(bytes, header::section_count);
    const std::uint64_t fitting  = (size - header_bytes) / table_entry_bytes;
    const std::uint64_t entries  = std::min(declared, fitting);
    for (std::uint64_t k = 0; k < entries; ++k)
      {
        const std::size_t   row    = header_bytes + table_entry_bytes * std::size_t(k);
        const std::size_t   scalar = scalar_bytes(get<std::uint32_t>(bytes, row + entry::scalar_type));
        const std::uint64_t offset = get<std::uint64_t>(bytes, row + entry::offset);
        const std::uint64_t count  = get<std::uint64_t>(bytes, row + entry::count);
        if (scalar == 0 || offset > size || count > (size - offset) / scalar)
          continue; // a reader refuses this entry before it reads the data
        put<std::uint32_t>(bytes, row + entry::crc32, crc32(bytes.data() + offset, std::size_t(count) * scalar));
      }
    put<std::uint32_t>(bytes, header::section_table_crc32,
                       crc32(bytes.data() + header_bytes, std::size_t(entries) * table_entry_bytes));
    put<std::uint32_t>(bytes, header::header_crc32, crc32(bytes.data(), header_crc_bytes));
  }

  bool write_basis_file(const std::string &path, const BasisContent &content, std::string *error)
  {
    const std::vector<unsigned char> bytes = write_basis(content);
    std::FILE                       *file  = std::fopen(path.c_str(), "wb");
    const bool ok = file && std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
    if (file && std::fclose(file) != 0)
      return false;
    if (!ok && error)
      *error = "cannot write " + path;
    return ok;
  }
} // namespace mrt
