#include "output/vtu_file.h"

#include <cstring>

namespace modal_haptics::vtu_file
{
  template <>
  const char *type_name<float>()
  {
    return "Float32";
  }
  template <>
  const char *type_name<double>()
  {
    return "Float64";
  }
  template <>
  const char *type_name<std::int32_t>()
  {
    return "Int32";
  }
  template <>
  const char *type_name<std::int64_t>()
  {
    return "Int64";
  }
  template <>
  const char *type_name<std::uint8_t>()
  {
    return "UInt8";
  }
  template <>
  const char *type_name<std::uint32_t>()
  {
    return "UInt32";
  }

  const char *byte_order()
  {
    const std::uint16_t one = 1;
    unsigned char       first;
    std::memcpy(&first, &one, 1);
    return first == 1 ? "LittleEndian" : "BigEndian";
  }

  namespace
  {
    // The DataArray element; 'offset' is where its byte count starts, counted from after the '_'.
    void declare(std::ostream &out, const Array &a, const std::uint64_t offset)
    {
      out << "<DataArray type=\"" << a.type << "\"";
      if (!a.name.empty())
        out << " Name=\"" << a.name << "\"";
      if (a.components != 1 || a.name.empty())
        out << " NumberOfComponents=\"" << a.components << "\"";
      out << " format=\"appended\" offset=\"" << offset << "\"/>\n";
    }

    // The arrays in the order in which the XML declares them, and so the block holds them.
    std::vector<const Array *> in_file_order(const Grid &g)
    {
      std::vector<const Array *> arrays{&g.points, &g.connectivity, &g.offsets, &g.types};
      for (const auto &a : g.point_data)
        arrays.push_back(&a);
      return arrays;
    }
  } // namespace

  void write(std::ostream &out, const Grid &grid)
  {
    const auto                 arrays = in_file_order(grid);
    std::vector<std::uint64_t> offsets;
    std::uint64_t              offset = 0;
    for (const Array *a : arrays)
      {
        offsets.push_back(offset);
        offset += sizeof(std::uint64_t) + a->bytes;
      }
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\""
        << byte_order() << "\" header_type=\"UInt64\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\""
        << grid.n_points << "\" NumberOfCells=\"" << grid.n_cells << "\">\n<Points>\n";
    declare(out, grid.points, offsets[0]);
    out << "</Points>\n<Cells>\n";
    for (std::size_t k = 1; k <= 3; ++k)
      declare(out, *arrays[k], offsets[k]);
    out << "</Cells>\n<PointData>\n";
    for (std::size_t k = 4; k < arrays.size(); ++k)
      declare(out, *arrays[k], offsets[k]);
    out << "</PointData>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";
    for (const Array *a : arrays)
      {
        const std::uint64_t bytes = a->bytes;
        out.write(reinterpret_cast<const char *>(&bytes), sizeof bytes);
        a->write(out);
      }
    out << "\n</AppendedData>\n</VTKFile>\n";
  }
} // namespace modal_haptics::vtu_file
