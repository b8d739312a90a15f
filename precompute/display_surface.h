// The scene's display/contact surface in SI units, with what every modal space shares on it:
// the region tag of each vertex (which VOI holds it), the lumped vertex areas and the contact
// patches (the weights that spread a HIP's force around its active vertex).
#pragma once

#include "scene_mesher.h"

#include <array>
#include <vector>

namespace modal_haptics
{
  struct DisplaySurface
  {
    std::vector<meshing::Point3>             vertices;  // [m]
    std::vector<std::array<unsigned int, 3>> triangles;
    std::vector<double>       vertex_area;   // a third of the adjacent triangles' area [m^2]
    std::vector<unsigned int> region;        // space index whose VOI holds the vertex, 0 = global
    double                    patch_radius = 0.; // rho [m]
    // Contact patches, CSR: the patch of v is entries [patch_offsets[v], patch_offsets[v+1]),
    // its first entry is v itself; weights sum to one.
    std::vector<unsigned int> patch_offsets;
    std::vector<unsigned int> patch_vertices;
    std::vector<double>       patch_weights;
    unsigned int              max_patch_size = 0;

    unsigned int n_vertices() const { return vertices.size(); }
  };

  // Scales the mesher's surface to metres, tags each vertex with the first VOI (1-based, in the order
  // given) that contains it, and builds the patches of radius patch_radius [m]:
  // w_j ~ A_j (1 - (d_j / rho)^2)^2 for d_j < rho, normalized (rho = 0: the vertex alone).
  DisplaySurface make_display_surface(const meshing::DisplaySurface                &surface,
                                      const std::vector<meshing::VolumeOfInterest> &volumes_of_interest,
                                      double length_unit,
                                      double patch_radius);
} // namespace modal_haptics
