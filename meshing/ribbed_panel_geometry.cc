#include "ribbed_panel_geometry.h"

#include "gmsh_tools.h"

#include <gmsh.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <set>
#include <sstream>

namespace modal_haptics::meshing::detail
{
  namespace
  {
    void require(const bool condition, const std::string &what)
    {
      if (!condition)
        throw MeshingError("built-in ribbed panel: " + what);
    }

    // The axes of the four bosses, inset from the plate's corners.
    std::vector<std::array<double, 2>> boss_axes(const RibbedPanelGeometry &g)
    {
      const double x = g.length / 2. - g.boss_inset, y = g.width / 2. - g.boss_inset;
      return {{{-x, -y}}, {{x, -y}}, {{-x, y}}, {{x, y}}};
    }

    // Features stand on the plate top; they start half-way into the plate so that the union
    // never has to merge coplanar touching faces (the fragile case of OCC booleans).
    double embedding(const RibbedPanelGeometry &g)
    {
      return g.wall_thickness / 2.;
    }

    DimTags add_ribs(const RibbedPanelGeometry &g)
    {
      DimTags ribs;
      for (std::size_t i = 0; i < g.rib_positions_y.size(); ++i)
        {
          const double t = g.rib_thicknesses[i];
          ribs.emplace_back(3, gmsh::model::occ::addBox(-g.rib_length / 2., g.rib_positions_y[i] - t / 2.,
                                                        g.wall_thickness - embedding(g), g.rib_length, t,
                                                        g.rib_heights[i] + embedding(g)));
        }
      return ribs;
    }

    DimTags add_boss_cylinders(const RibbedPanelGeometry &g)
    {
      DimTags bosses;
      for (const auto &axis : boss_axes(g))
        bosses.emplace_back(3, gmsh::model::occ::addCylinder(axis[0], axis[1], g.wall_thickness - embedding(g), 0., 0.,
                                                             g.boss_height + embedding(g), g.boss_outer_radius));
      return bosses;
    }

    int add_clip_tower(const RibbedPanelGeometry &g)
    {
      const double s = g.clip_size;
      return gmsh::model::occ::addBox(g.clip_centre[0] - s / 2., g.clip_centre[1] - s / 2.,
                                      g.wall_thickness - embedding(g), s, s, g.clip_height + embedding(g));
    }

    // What is cut away: the screw holes (blind, down to the plate top) and the tower's inside.
    // The cutters reach above the tops so that no cutter face is coplanar with a top face.
    DimTags add_cavities(const RibbedPanelGeometry &g)
    {
      DimTags      cavities;
      const double overshoot = 1. + g.boss_height + g.clip_height;
      if (g.boss_inner_radius > 0.)
        for (const auto &axis : boss_axes(g))
          cavities.emplace_back(3, gmsh::model::occ::addCylinder(axis[0], axis[1], g.wall_thickness, 0., 0., overshoot,
                                                                 g.boss_inner_radius));
      const double inner = g.clip_size - 2. * g.clip_wall;
      cavities.emplace_back(3, gmsh::model::occ::addBox(g.clip_centre[0] - inner / 2., g.clip_centre[1] - inner / 2.,
                                                        g.wall_thickness, inner, inner, overshoot));
      return cavities;
    }

    // The top annular faces of the bosses: every face lying in the plane of the boss tops within
    // a boss's footprint.
    std::vector<int> boss_top_faces(const RibbedPanelGeometry &g)
    {
      const double     top = g.wall_thickness + g.boss_height, r = g.boss_outer_radius, tolerance = 1e-3 * r;
      std::vector<int> faces;
      for (const auto &axis : boss_axes(g))
        {
          const auto found =
            entities_inside_box(2, {axis[0] - r, axis[1] - r, top}, {axis[0] + r, axis[1] + r, top}, tolerance);
          require(!found.empty(), "the top face of the boss at x = " + std::to_string(axis[0]) +
                                    ", y = " + std::to_string(axis[1]) + " was not found (is it covered by a rib?)");
          faces.insert(faces.end(), found.begin(), found.end());
        }
      return faces;
    }

    void add_groups(const RibbedPanelGeometry &g, const int volume)
    {
      const std::vector<int> clamp = boss_top_faces(g);
      const std::set<int>    clamp_set(clamp.begin(), clamp.end());
      std::vector<int>       free;
      for (const int face : boundary_faces())
        if (clamp_set.count(face) == 0)
          free.push_back(face);
      add_named_group(3, {volume}, "part", part_group_tag);
      add_named_group(2, clamp, "clamp", clamp_group_tag);
      add_named_group(2, free, "free", free_group_tag);
    }
  } // namespace

  void check_ribbed_panel(const RibbedPanelGeometry &g)
  {
    require(g.length > 0. && g.width > 0. && g.wall_thickness > 0., "length, width and wall thickness must be > 0");
    require(g.rib_heights.size() == g.rib_positions_y.size() && g.rib_thicknesses.size() == g.rib_positions_y.size(),
            "rib positions, heights and thicknesses must have the same number of entries");
    require(g.rib_length > 0. && g.rib_length <= g.length, "rib length must be in (0, length]");
    for (std::size_t i = 0; i < g.rib_positions_y.size(); ++i)
      {
        const std::string rib = "rib " + std::to_string(i + 1) + ": ";
        require(g.rib_heights[i] > 0. && g.rib_thicknesses[i] > 0., rib + "height and thickness must be > 0");
        require(std::abs(g.rib_positions_y[i]) + g.rib_thicknesses[i] / 2. < g.width / 2.,
                rib + "must lie on the plate (|y| + thickness/2 < width/2)");
      }
    require(g.boss_outer_radius > 0. && g.boss_height > 0., "boss outer radius and height must be > 0");
    require(g.boss_inner_radius >= 0. && g.boss_inner_radius < g.boss_outer_radius,
            "boss inner radius must be in [0, outer radius)");
    require(g.boss_inset > g.boss_outer_radius, "boss inset must be larger than the boss outer radius");
    require(2. * g.boss_inset < std::min(g.length, g.width), "boss inset must be less than half the plate's size");
    require(g.clip_wall > 0. && g.clip_size > 2. * g.clip_wall && g.clip_height > 0.,
            "clip tower needs wall > 0, size > 2 wall and height > 0");
    require(std::abs(g.clip_centre[0]) + g.clip_size / 2. < g.length / 2. &&
              std::abs(g.clip_centre[1]) + g.clip_size / 2. < g.width / 2.,
            "clip tower must lie on the plate");
  }

  void build_ribbed_panel(const RibbedPanelGeometry &g)
  {
    check_ribbed_panel(g);
    namespace occ = gmsh::model::occ;
    const int plate    = occ::addBox(-g.length / 2., -g.width / 2., 0., g.length, g.width, g.wall_thickness);
    DimTags   features = add_ribs(g);
    const DimTags bosses = add_boss_cylinders(g);
    features.insert(features.end(), bosses.begin(), bosses.end());
    features.emplace_back(3, add_clip_tower(g));

    DimTags                 fused, part;
    std::vector<DimTags>    history;
    occ::fuse({{3, plate}}, features, fused, history);
    occ::cut(fused, add_cavities(g), part, history);
    occ::synchronize();

    require(part.size() == 1 && part.front().first == 3,
            "the union of plate, ribs, bosses and tower is not one volume (" + std::to_string(part.size()) +
              " entities)");
    add_groups(g, part.front().second);
  }

  std::string describe_ribbed_panel(const RibbedPanelGeometry &g)
  {
    std::ostringstream out;
    out << std::setprecision(17) << "ribbed_panel length=" << g.length << " width=" << g.width
        << " wall=" << g.wall_thickness << " rib_length=" << g.rib_length << " ribs=";
    for (std::size_t i = 0; i < g.rib_positions_y.size(); ++i)
      out << '(' << g.rib_positions_y[i] << ',' << (i < g.rib_heights.size() ? g.rib_heights[i] : 0.) << ','
          << (i < g.rib_thicknesses.size() ? g.rib_thicknesses[i] : 0.) << ')';
    out << " boss=(" << g.boss_inset << ',' << g.boss_outer_radius << ',' << g.boss_inner_radius << ','
        << g.boss_height << ") clip=(" << g.clip_centre[0] << ',' << g.clip_centre[1] << ',' << g.clip_size << ','
        << g.clip_wall << ',' << g.clip_height << ')';
    return out.str();
  }
} // namespace modal_haptics::meshing::detail
