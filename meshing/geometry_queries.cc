// Queries of the loaded gmsh model that inspect the geometry without meshing it (mesher_parts.h):
// sizes, areas and bounding boxes, and what a named group, a VOI or a support's box or plane meets.
#include "mesher_parts.h"

#include <gmsh.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace modal_haptics::meshing::detail
{
  // The part's volume [unit^3] from OpenCASCADE; 0 for gmsh's built-in kernel, which has none.
  double part_volume()
  {
    DimTags volumes;
    gmsh::model::getEntities(volumes, 3);
    double total = 0.;
    try
      {
        for (const auto &[dim, tag] : volumes)
          {
            double volume = 0.;
            gmsh::model::occ::getMass(dim, tag, volume);
            total += volume;
          }
      }
    catch (...)
      {
        return 0.;
      }
    return total;
  }

  // The part's bounding box [unit] (OpenCASCADE pads it by about 1e-7).
  std::array<Point3, 2> bounding_box(const int dim, const int tag)
  {
    std::array<Point3, 2> box{};
    gmsh::model::getBoundingBox(dim, tag, box[0][0], box[0][1], box[0][2], box[1][0], box[1][1], box[1][2]);
    return box;
  }

  // How far a selection box must be widened to catch a whole face.
  double growth_to_catch(const std::array<Point3, 2> &box, const std::array<Point3, 2> &face)
  {
    double growth = 0.;
    for (int i = 0; i < 3; ++i)
      growth = std::max({growth, box[0][i] - face[0][i], face[1][i] - box[1][i]});
    return growth;
  }

  double face_area(const int face)
  {
    double area = 0.;
    gmsh::model::occ::getMass(2, face, area);
    return area;
  }

  // The area of a mesh surface entity's triangles (a .msh input).
  double mesh_area(const int face)
  {
    std::vector<std::size_t> elements, element_nodes, node_tags;
    std::vector<double>      coordinates, parametric;
    gmsh::model::mesh::getElementsByType(2, elements, element_nodes, face);
    gmsh::model::mesh::getNodes(node_tags, coordinates, parametric, 2, face, true, false);
    std::unordered_map<std::size_t, std::size_t> position;
    for (std::size_t i = 0; i < node_tags.size(); ++i)
      position[node_tags[i]] = 3 * i;
    double area = 0.;
    for (std::size_t t = 0; t + 2 < element_nodes.size(); t += 3)
      {
        const double *a = &coordinates[position[element_nodes[t]]], *b = &coordinates[position[element_nodes[t + 1]]],
                     *c = &coordinates[position[element_nodes[t + 2]]];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        area += 0.5 * std::sqrt(std::pow(u[1] * v[2] - u[2] * v[1], 2) + std::pow(u[2] * v[0] - u[0] * v[2], 2) +
                                std::pow(u[0] * v[1] - u[1] * v[0], 2));
      }
    return area;
  }

  // How far apart two boxes are (<= 0: they meet).
  double box_gap(const std::array<Point3, 2> &region, const std::array<Point3, 2> &f)
  {
    double gap = -std::numeric_limits<double>::max();
    for (int i = 0; i < 3; ++i)
      gap = std::max({gap, f[0][i] - region[1][i], region[0][i] - f[1][i]});
    return gap;
  }

  // The boundary faces whose bounding box is within gap(box) <= 0; when there is none, 'why'
  // names the nearest.
  SelectionReport faces_meeting(const std::string &name, const std::function<double(const std::array<Point3, 2> &)> &gap,
                                std::string &why)
  {
    SelectionReport caught;
    caught.name        = name;
    int        nearest = 0;
    double     nearest_gap = std::numeric_limits<double>::max();
    const bool occ     = part_volume() > 0.; // areas from OpenCASCADE, none for gmsh's built-in kernel
    for (const int face : boundary_faces())
      {
        const double face_gap = gap(bounding_box(2, face));
        if (face_gap <= 0.)
          {
            ++caught.n_faces;
            caught.area += occ ? face_area(face) : 0.;
          }
        else if (face_gap < nearest_gap)
          {
            nearest_gap = face_gap;
            nearest     = face;
          }
      }
    if (caught.n_faces == 0)
      {
        std::ostringstream text;
        text << "no boundary face's bounding box meets it";
        if (nearest > 0)
          {
            const auto f = bounding_box(2, nearest);
            text << "; the nearest is face " << nearest << " with bounding box " << readable_point(f[0]) << "-"
                 << readable_point(f[1]) << ", " << nearest_gap << " away";
          }
        why = text.str();
      }
    return caught;
  }

  // Points on a CAD entity that 'keep' accepts, with the surface's normal at each (zero on a curve or a
  // point): a grid over a surface's parametrization within its trims, points along a curve, a
  // point itself. What --validate predicts a support holds.
  std::vector<std::array<Point3, 2>> samples_on(const int dim, const int tag, const std::function<bool(const Point3 &)> &keep)
  {
    constexpr int              per_side = 9;
    std::vector<double>        parametric, coordinates, normals, low, high;
    if (dim > 0)
      {
        gmsh::model::getParametrizationBounds(dim, tag, low, high);
        for (int i = 0; i < per_side; ++i)
          for (int j = 0; j < (dim == 2 ? per_side : 1); ++j)
            {
              const std::array<double, 2> uv{{low[0] + (high[0] - low[0]) * (i + 0.5) / per_side,
                                              dim == 2 ? low[1] + (high[1] - low[1]) * (j + 0.5) / per_side : 0.}};
              if (dim == 1 || gmsh::model::isInside(2, tag, {uv[0], uv[1]}) > 0)
                parametric.insert(parametric.end(), uv.begin(), uv.begin() + dim);
            }
        if (parametric.empty())
          return {};
      }
    gmsh::model::getValue(dim, tag, parametric, coordinates);
    if (dim == 2)
      gmsh::model::getNormal(tag, parametric, normals);
    std::vector<std::array<Point3, 2>> samples;
    for (std::size_t p = 0; 3 * p + 2 < coordinates.size(); ++p)
      {
        const Point3 x{{coordinates[3 * p], coordinates[3 * p + 1], coordinates[3 * p + 2]}};
        const Point3 n = dim == 2 ? Point3{{normals[3 * p], normals[3 * p + 1], normals[3 * p + 2]}} : Point3{};
        if (keep(x))
          samples.push_back({{x, n}});
      }
    return samples;
  }

  // A named physical group of the model (or of the .msh file): its entities, a surface's area.
  SelectionReport inspect_group(const InputKind kind, const std::string &geometry, const int group_dim,
                                const std::string &name)
  {
    static const char *const kinds[3] = {"point", "curve", "surface"};
    const std::string        kind_name = kinds[group_dim];
    SelectionReport          caught;
    caught.name   = "Group '" + name + "' (a physical " + kind_name + ")";
    caught.entity = group_dim == 2 ? "face" : kind_name;
    std::vector<std::string> known;
    call_gmsh("the groups of geometry '" + geometry + "'", [&] {
      DimTags groups;
      gmsh::model::getPhysicalGroups(groups, group_dim);
      // Areas from OpenCASCADE, from a .msh's triangles; none for gmsh's built-in kernel.
      const bool occ = kind != InputKind::msh && part_volume() > 0.;
      for (const auto &[dim, tag] : groups)
        {
          std::string group_name;
          gmsh::model::getPhysicalName(dim, tag, group_name);
          if (!added_by_program(dim, group_name))
            known.push_back(group_name);
          if (group_name != name)
            continue;
          std::vector<int> entities;
          gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
          caught.n_faces = entities.size();
          if (dim == 2)
            for (const int face : entities)
              caught.area += occ ? face_area(face) : kind == InputKind::msh ? mesh_area(face) : 0.;
          for (const int entity : entities)
            if (kind != InputKind::msh)
              for (const auto &sample : samples_on(dim, entity, [](const Point3 &) { return true; }))
                caught.samples.push_back(sample);
        }
    });
    if (caught.n_faces == 0)
      {
        std::string list;
        for (const auto &k : known)
          list += (list.empty() ? "'" : ", '") + k + "'";
        throw MeshingError("Group '" + name + "' ('Geometry/Supports' or 'Clamp groups') is not a physical " +
                           kind_name + " of geometry '" + geometry + "' (its physical " + kind_name +
                           "s: " + (list.empty() ? "none" : list) +
                           (added_by_program(group_dim, "free") ?
                              "; the program adds 'free', the boundary faces in no group" : "") +
                           (kind == InputKind::cad && group_dim == 2 ?
                              "; STEP/IGES/BREP files get 'clamp' from 'Clamp boxes' and 'free' for the rest; "
                              "select their faces with box, plane or normal supports" :
                              "") +
                           ")");
      }
    return caught;
  }

  // The CAD surfaces whose outward normal lies within the selection's angle of its direction, and
  // samples of them. None found is not refused here: the run decides on the mesh's faces.
  SelectionReport inspect_normal_selection(const RegionSelection &selection)
  {
    SelectionReport caught;
    caught.name         = selection.label;
    const double length = std::sqrt(std::pow(selection.normal[0], 2) + std::pow(selection.normal[1], 2) +
                                    std::pow(selection.normal[2], 2));
    const double lowest = std::cos(std::max(selection.angle_degrees, 1e-4) * M_PI / 180.);
    const bool   occ    = part_volume() > 0.; // areas from OpenCASCADE, none for gmsh's built-in kernel
    for (const int face : boundary_faces())
      {
        std::size_t before = caught.samples.size();
        for (const auto &sample : samples_on(2, face, [](const Point3 &) { return true; }))
          {
            const auto  &n      = sample[1];
            const double cosine = (n[0] * selection.normal[0] + n[1] * selection.normal[1] + n[2] * selection.normal[2]) /
                                  (length * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) + 1e-300);
            if (cosine >= lowest)
              caught.samples.push_back(sample);
          }
        caught.n_faces += caught.samples.size() > before;
        caught.area += caught.samples.size() > before && occ ? face_area(face) : 0.;
      }
    return caught;
  }

  // A support's box, plane or normal direction (supports are resolved on each mesh; here whether it
  // can catch anything, and samples of what it meets): the CAD surfaces whose bounding box meets a
  // box or a plane, refused when there is none.
  SelectionReport inspect_region(const RegionSelection &selection, const std::string &geometry)
  {
    if (selection.kind == RegionSelection::Kind::normal)
      return inspect_normal_selection(selection);
    const auto   part      = bounding_box();
    double       diagonal2 = 0.;
    for (int i = 0; i < 3; ++i)
      diagonal2 += std::pow(part[1][i] - part[0][i], 2);
    const double tolerance = 1e-5 * std::sqrt(diagonal2);
    const auto   gap       = [&](const std::array<Point3, 2> &f) {
      if (selection.kind == RegionSelection::Kind::box)
        return box_gap({selection.lower, selection.upper}, f) - tolerance;
      double n2 = 0., lowest = std::numeric_limits<double>::max(), highest = -lowest;
      for (int i = 0; i < 3; ++i)
        n2 += selection.normal[i] * selection.normal[i];
      for (int corner = 0; corner < 8; ++corner)
        {
          double distance = 0.;
          for (int i = 0; i < 3; ++i)
            distance += (((corner >> i & 1) ? f[1][i] : f[0][i]) - selection.point[i]) * selection.normal[i];
          distance /= std::sqrt(n2);
          lowest  = std::min(lowest, distance);
          highest = std::max(highest, distance);
        }
      return (lowest <= 0. && highest >= 0. ? 0. : std::min(std::abs(lowest), std::abs(highest))) - tolerance;
    };
    std::string why;
    auto        caught = faces_meeting(selection.label, gap, why);
    if (caught.n_faces == 0)
      throw MeshingError(selection.label + " of geometry '" + geometry + "' catches no CAD surface: " +
                         why + " (units of the geometry)");
    const auto inside = [&](const Point3 &x) { return gap({{x, x}}) <= 0.; };
    for (const int face : boundary_faces())
      for (const auto &sample : samples_on(2, face, inside))
        caught.samples.push_back(sample);
    return caught;
  }
} // namespace modal_haptics::meshing::detail
