#include "pipeline/geometry_check.h"

#include "parameters/parameter_text.h"
#include "space/space_parts.h"

#include <deal.II/base/exceptions.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using parameter_text::text;

  namespace
  {
    using Kind   = SupportSelection::Kind;
    using Region = meshing::RegionSelection;

    bool names_a_group(const SupportSelection &s)
    {
      return s.kind == Kind::surface || s.kind == Kind::curve || s.kind == Kind::point;
    }

    // What meshing::inspect_geometry is asked about the supports, in their order: the named groups,
    // and the boxes, planes and normal directions.
    struct Selections
    {
      std::vector<std::pair<int, std::string>> named_groups;
      std::vector<Region>                      regions;
    };

    Selections selections_of(const std::vector<Support> &supports)
    {
      Selections out;
      for (const auto &support : supports)
        {
          const auto       &s     = support.selection;
          const std::string label = "The selection of " + support.label();
          if (names_a_group(s))
            out.named_groups.emplace_back(s.named_dimension(), s.name);
          else if (s.kind == Kind::box || s.kind == Kind::nodes)
            out.regions.push_back({label, Region::Kind::box, s.lower, s.upper, {}, {}, 0.});
          else if (s.kind == Kind::plane)
            out.regions.push_back({label, Region::Kind::plane, {}, {}, s.point, s.direction, 0.});
          else
            out.regions.push_back({label, Region::Kind::normal, {}, {}, {}, s.direction, s.angle_degrees});
        }
      return out;
    }

    // The part's extent along x, y, z [geometry units].
    std::array<double, 3> extents(const meshing::GeometryReport &report)
    {
      return {{report.upper[0] - report.lower[0], report.upper[1] - report.lower[1], report.upper[2] - report.lower[2]}};
    }

    std::string metres(const meshing::Point3 &p, const double unit)
    {
      std::ostringstream out;
      out << std::setprecision(5) << "(" << p[0] * unit << ", " << p[1] * unit << ", " << p[2] * unit << ")";
      return out.str();
    }

    // A length of the bounding box, to 5 digits: OpenCASCADE pads it by about 1e-7 units.
    std::string rounded(const double length)
    {
      std::ostringstream out;
      out << std::setprecision(5) << length;
      return out.str();
    }

    // A .msh geometry is the mesh itself: nothing is meshed, the size parameters are not used.
    bool given_as_mesh(const std::string &geometry)
    {
      return geometry.size() > 4 && geometry.substr(geometry.size() - 4) == ".msh";
    }

    // "3 CAD surfaces": what the geometry's selections count (the run counts mesh faces); a .msh
    // input's groups hold the mesh's surfaces.
    std::string counted(const std::size_t n, const std::string &entity, const std::string &geometry)
    {
      const std::string what = entity != "face" ? entity : given_as_mesh(geometry) ? "surface" : "CAD surface";
      return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
    }

    // The [geometry] lines of the unit, the bounding box, the volume and the mass.
    std::string part_summary(const SceneParameters &scene, const meshing::GeometryReport &report)
    {
      const double       unit = scene.length_unit;
      const auto         e    = extents(report);
      std::ostringstream out;
      out << std::setprecision(6) << "[geometry] '" << scene.meshing.geometry << "': ";
      if (report.unit.metres > 0.)
        out << "the file declares its lengths in " << report.unit.name << ", read as they are: " << unit
            << " m per unit (= 'Geometry/Length unit')\n";
      else
        out << "no declared unit: 'Geometry/Length unit' = " << unit << " m per unit\n";
      // OpenCASCADE pads bounding boxes by about 1e-7 units: 5 significant digits hide it.
      out << std::setprecision(5) << "[geometry] bounding box " << metres(report.lower, unit) << " - "
          << metres(report.upper, unit) << " m, extent " << e[0] * unit << " x " << e[1] * unit << " x "
          << e[2] * unit << " m\n" << std::setprecision(6);
      const double volume = report.volume * unit * unit * unit;
      if (volume > 0.)
        out << "[geometry] volume " << volume << " m^3, mass " << volume * scene.material.density
            << " kg (density " << scene.material.density << " kg/m^3)\n";
      else
        out << "[geometry] volume unknown before meshing (gmsh's built-in geometry kernel)\n";
      return out.str();
    }

    // The [geometry] lines of what each group, clamp box, support selection and VOI meets.
    std::string selection_summary(const SceneParameters &scene, const meshing::GeometryReport &report)
    {
      const double       unit = scene.length_unit;
      std::ostringstream out;
      for (const auto &groups : {report.named_groups, report.clamp_boxes})
        for (const auto &selection : groups)
          {
            out << "[geometry] " << selection.name << ": " << counted(selection.n_faces, selection.entity, scene.meshing.geometry);
            if (selection.area > 0.)
              out << ", area " << selection.area * unit * unit << " m^2";
            out << "\n";
          }
      for (const auto &region : report.regions)
        out << "[geometry] " << region.name << ": meets " << counted(region.n_faces, "face", scene.meshing.geometry)
            << " (the run selects the mesh faces or nodes inside)\n";
      for (const auto &voi : report.volumes_of_interest)
        {
          out << "[geometry] " << voi.name << ": meets " << counted(voi.n_faces, "face", scene.meshing.geometry);
          if (voi.area > 0.)
            out << " (their whole area: " << voi.area * unit * unit << " m^2)";
          out << "\n";
        }
      return out.str();
    }

    // What the unit decides, before meshing: a coarse size larger than the part cannot give a mesh
    // (refused); a part under a millimetre or over 10 m, under a milligram or over 10 t, a coarse
    // size over a third of the part, a patch over a tenth of it are warned about (printed when 'warn').
    // The sizes only where the program meshes (not for a .msh geometry).
    void check_sizes(const SceneParameters &scene, const meshing::GeometryReport &report, const bool warn)
    {
      const auto   e       = extents(report);
      const double largest = std::max({e[0], e[1], e[2]}), unit = scene.length_unit;
      if (largest <= 0.)
        return;
      const std::string extent = rounded(largest) + " geometry units (" + rounded(largest * unit) + " m)";
      const std::string is_the_unit_right = "is 'Geometry/Length unit' = " + text(unit) + " m right?";
      const bool meshed_here = !given_as_mesh(scene.meshing.geometry);
      AssertThrow(!meshed_here || scene.meshing.coarse_size <= largest,
                  ExcMessage("'Meshing/Coarse size' = " + text(scene.meshing.coarse_size) + " geometry units (" +
                             text(scene.meshing.coarse_size * unit) + " m) is larger than the part's largest extent, " +
                             extent + ": the mesh would be a handful of tets. Give the sizes in the geometry's unit: " +
                             is_the_unit_right));
      if (!warn)
        return;
      if (largest * unit < 1e-3 || largest * unit > 10.)
        std::cerr << "Warning: the part measures " << largest * unit << " m across: " << is_the_unit_right << std::endl;
      const double mass = report.volume * unit * unit * unit * scene.material.density;
      if (report.volume > 0. && (mass < 1e-6 || mass > 1e4))
        std::cerr << "Warning: the part's mass is " << mass << " kg (density " << scene.material.density
                  << " kg/m^3): " << is_the_unit_right << " Or 'Material/Density'?" << std::endl;
      if (meshed_here && scene.meshing.coarse_size > largest / 3.)
        std::cerr << "Warning: 'Meshing/Coarse size' = " << scene.meshing.coarse_size
                  << " geometry units is over a third of the part's largest extent, " << extent
                  << ": a few elements across the part. Are the sizes in the geometry's unit?" << std::endl;
      // A patch that covers a large share of the part is no longer a contact.
      if (scene.contact.patch_radius > 0.1 * largest)
        std::cerr << "Warning: 'Contact/Patch radius' = " << scene.contact.patch_radius << " geometry units ("
                  << scene.contact.patch_radius * unit << " m) exceeds a tenth of the part's largest extent, " << extent
                  << ": the patch covers much of the part. " << is_the_unit_right << std::endl;
    }

    // A group the file names but gives nothing to (gmsh loads one without a word) is left out of the
    // meshes; no support names it, or inspect_geometry would have refused the run.
    void warn_about_empty_groups(const SceneParameters &scene, const meshing::GeometryReport &report)
    {
      for (const auto &words : report.empty_groups)
        std::cerr << "Warning: geometry file '" << scene.meshing.geometry << "': " << words
                  << "; it is left out of the meshes (no support names it)." << std::endl;
    }

    // The rigid-body motions the supports would leave free, from points on what each selection
    // meets in the CAD model and the directions its restraint holds there (the run finds them on
    // each mesh's nodes). None when a selection has no such points (a .msh input, a normal
    // selection that finds no surface before meshing): the run decides.
    std::optional<FreeMotions> predicted_free_motions(const SceneParameters &scene, const meshing::GeometryReport &report)
    {
      const auto   e    = extents(report);
      const double unit = scene.length_unit;
      ResolvedSupports supports;
      supports.part_diagonal = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) * unit;
      std::size_t group = 0, region = 0;
      for (const auto &support : scene.supports)
        {
          const auto &caught = names_a_group(support.selection) ? report.named_groups.at(group++) :
                                                                  report.regions.at(region++);
          if (caught.samples.empty())
            return std::nullopt;
          for (const auto &[x, n] : caught.samples)
            {
              const dealii::Point<3> at(x[0] * unit, x[1] * unit, x[2] * unit);
              dealii::Tensor<1, 3>   normal({n[0], n[1], n[2]});
              normal /= normal.norm() > 0. ? normal.norm() : 1.;
              for (const auto &d : held_directions(support.restraint, at, normal, unit, 1e-6 * supports.part_diagonal))
                supports.held.emplace_back(at, d);
            }
        }
      return supports.free_motions(dealii::Point<3>());
    }
  } // namespace

  void check_geometry(const SceneParameters &scene, const bool print, const bool predict_free_motions)
  {
    const auto selections = selections_of(scene.supports);
    const auto report     = meshing::inspect_geometry(scene.meshing, scene.volumes_of_interest, selections.named_groups,
                                                      selections.regions, scene.length_unit);
    if (print)
      std::cout << part_summary(scene, report) << selection_summary(scene, report) << std::flush;
    check_sizes(scene, report, print);
    if (print)
      warn_about_empty_groups(scene, report);
    if (!predict_free_motions || scene.supports.empty())
      return;
    if (const auto free = predicted_free_motions(scene, report))
      {
        if (print)
          std::cout << "[geometry] the supports would leave " << free->motions.size() << " rigid-body motion"
                    << (free->motions.size() == 1 ? "" : "s") << " free"
                    << (free->motions.empty() ? "" : " (" + free->describe() + ")") << std::endl;
        space_parts::check_free_motions(scene, *free, "");
      }
  }
} // namespace modal_haptics
