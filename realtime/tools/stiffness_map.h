// The felt-stiffness map of a basis (.mrt FELT_STIFFNESS, modalrt_basis_felt_stiffness) as modal-rt
// info prints it and the view draws it: the scene's map takes each display vertex from the space of
// its region (DISPLAY_REGION), where a HIP pressing there is. And the validity map
// (VALIDITY_FORCE, modalrt_basis_validity_forces: where linear stops being true) as info prints it.
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt_tool
{
  // Whether the file holds a map (a .mrt 1.1 from a precompute that computed it).
  bool has_felt_stiffness_map(const modalrt_basis *basis);

  // The scene's map at `vertex` [N/m]: its region's space's value; 0 where that space did not
  // compute it or the file has no map.
  double scene_felt_stiffness(const modalrt_basis *basis, std::uint32_t vertex);

  // modal-rt info --basis: per space, the map over its region (how many of its vertices have a value,
  // min / median / max in N/mm) and its `softest` softest spots (vertex, rest position in mm, N/mm).
  void print_felt_stiffness_map(const modalrt_basis *basis, std::uint32_t softest = 5);

  // modal-rt info --vertex: the scene's map at `vertex`, one line.
  void print_vertex_felt_stiffness(const modalrt_basis *basis, std::uint32_t vertex);

  // Whether any space of the basis has a validity map (VALIDITY_FORCE, .mrt 1.2).
  bool has_validity_map(const modalrt_basis *basis);

  // The validity force [N] of a contact in `space` at `level` [%] (1, 5, 10) as the kernel compares it
  // (MODALRT_HIP_BEYOND_VALIDITY): at a proxy's point (`triangle` not MODALRT_NONE, its `weights`) the
  // blend of modalrt_basis_point_validity_force, else the stored value of `vertex`; 0 where none.
  double contact_validity_force(const modalrt_basis *basis, std::uint32_t space, std::uint32_t vertex,
                                std::uint32_t triangle, const double weights[3], std::uint32_t level);

  // modal-rt info --basis: per space, the validity map (VALIDITY_FORCE, .mrt 1.2) over its region: how
  // many vertices have an F5, and the `lowest` of them (vertex, rest position in mm, F1, F5, F10 in N).
  void print_validity_map(const modalrt_basis *basis, std::uint32_t lowest = 5);

  // modal-rt info --vertex: the validity forces at `vertex` in its region's space, one line.
  void print_vertex_validity(const modalrt_basis *basis, std::uint32_t vertex);
} // namespace modalrt_tool
