// A VTK XML UnstructuredGrid (.vtu) with its arrays appended as raw binary: format="appended",
// encoding="raw", header_type="UInt64", in the machine's byte order. Each array's values are
// written once, after the XML, behind their byte count: a quarter smaller than base64, smaller than
// ASCII, and what ParaView and VTK read natively (docs/precompute.md). No deal.II: the mode shapes
// (space/phase_output.h) and the display-surface maps (export_results.cc) both write through it.
#pragma once

#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace modal_haptics::vtu_file
{
  // One DataArray: its attributes, its size and what writes its values (raw, the machine's order).
  struct Array
  {
    std::string                         type;       // VTK's type name: Float32, Float64, Int32, Int64, UInt8, UInt32
    std::string                         name;       // empty: no Name attribute (Points)
    unsigned int                        components = 1;
    std::uint64_t                       bytes      = 0; // what 'write' puts out
    std::function<void(std::ostream &)> write;
  };

  // VTK's name of a value type.
  template <typename T>
  const char *type_name();

  // An array that owns its values (components interleaved: x0 y0 z0 x1 ...).
  template <typename T>
  Array owned_array(const std::string &name, unsigned int components, std::vector<T> values)
  {
    Array a;
    a.type       = type_name<T>();
    a.name       = name;
    a.components = components;
    a.bytes      = values.size() * sizeof(T);
    a.write      = [values = std::move(values)](std::ostream &out) {
      out.write(reinterpret_cast<const char *>(values.data()), std::streamsize(values.size() * sizeof(T)));
    };
    return a;
  }

  struct Grid
  {
    std::uint64_t      n_points = 0, n_cells = 0;
    Array              points;                         // Float32 or Float64, 3 components
    Array              connectivity, offsets, types;   // the Cells
    std::vector<Array> point_data;
  };

  // "LittleEndian" or "BigEndian": the machine's, in which the values and the byte counts are written.
  const char *byte_order();

  // The whole file: the XML (each DataArray's offset into the appended block), then the block:
  // '_' and, per array in the order of the XML, its byte count (UInt64) and its bytes.
  void write(std::ostream &out, const Grid &grid);
} // namespace modal_haptics::vtu_file
