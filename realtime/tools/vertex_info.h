// `modal-rt info --vertex N` and `--near x,y,z`: where one display vertex is and what a hand feels
// there (without it, nothing tells an integrator where a part's vertices and normals are). Every
// number comes from the kernel's C API: rest positions, the area-weighted outward normals the contact
// uses, DISPLAY_REGION, the candidates, and modalrt_basis_contact_compliance for the felt stiffness.
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt_tool
{
  // The static compliance of a contact at `vertex` in `space` along the vertex's outward normal n,
  // n^T G n [m/N] with G from modalrt_basis_contact_compliance (B Lambda^-1 B^T, plus the stored
  // correction C at a candidate: then full_fe). Its inverse is the stiffness a HIP pressing straight
  // in feels statically. Returns the call's status (ERROR_VALUE: a space with a free mode has none).
  int normal_compliance(const modalrt_basis *basis, std::uint32_t space, std::uint32_t vertex, double &compliance,
                        bool &full_fe);

  // Where a proxy contact sits, what a HIP pressing straight in feels there: the point of display
  // triangle `triangle` at barycentric weights `weights`, its rest position [m] and outward unit
  // normal n (the corners' blended, as the kernel's), and n^T G n [m/N] with G from
  // modalrt_basis_point_compliance (full_fe: the full-FE compliance of the blended load).
  int point_normal_compliance(const modalrt_basis *basis, std::uint32_t space, std::uint32_t triangle,
                              const double weights[3], double rest[3], double normal[3], double &compliance,
                              bool &full_fe);

  // The display vertex closest to `point` [m] (body frame, rest); its distance [m] in `distance`.
  std::uint32_t nearest_vertex(const modalrt_basis *basis, const double point[3], double &distance);

  // Prints the vertex's position, normal, region, the spaces where it is a candidate and its felt
  // stiffness in every space.
  void print_vertex(const modalrt_basis *basis, std::uint32_t vertex);
} // namespace modalrt_tool
