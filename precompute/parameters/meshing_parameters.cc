// The .prm subsections of the meshing stage's structs (meshing/scene_mesher.h has no deal.II):
// "Geometry" (with its supports and the built-in panel), "Meshing" and the "Scenario N" VOIs, and
// the readers of lists and points every subsection uses (parameter_sections.h).
#include "parameters/parameter_sections.h"
#include "parameters/parameter_text.h"
#include "parameters/scene_parameters.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <set>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using dealii::ParameterHandler;
  using parameter_text::Notation;
  using parameter_text::text;
  namespace Patterns = dealii::Patterns;

  // ---- Reading lists back (parameter_text.h writes the defaults) -------------------------------------
  namespace parameter_sections
  {
    const std::string point_pattern_help = " Three comma-separated numbers x, y, z.";
    // The unit of every length of the .prm file.
    const std::string geometry_units =
      " Units: geometry units ('Geometry/Length unit' metres each: mm by default and for the built-in panel; a "
      "STEP/IGES file's declared unit).";

    meshing::Point3 parse_point(const std::string &text, const std::string &entry)
    {
      const auto values = dealii::Utilities::string_to_double(
        dealii::Utilities::split_string_list(text, ','));
      AssertThrow(values.size() == 3,
                  ExcMessage("Parameter '" + entry + "' needs three numbers x, y, z, got '" + text + "'."));
      return {{values[0], values[1], values[2]}};
    }

    std::vector<double> parse_doubles(const std::string &text)
    {
      return dealii::Utilities::string_to_double(dealii::Utilities::split_string_list(text, ','));
    }
  } // namespace

  // ---- The meshing stage's structs (meshing/scene_mesher.h has no deal.II) ---------------------------
  namespace parameter_sections
  {
    // Subsection "Geometry/Ribbed panel": the built-in part. Its scalar defaults are printed with
    // std::to_string ("300.000000"), as they always were in used_parameters.prm.
    void declare_ribbed_panel(ParameterHandler &prm)
    {
      const meshing::RibbedPanelGeometry g;
      const auto length = [&](const char *name, const double value, const std::string &what) {
        prm.declare_entry(name, std::to_string(value), Patterns::Double(1e-6), what + geometry_units);
      };
      prm.enter_subsection("Ribbed panel");
      prm.declare_entry("Length", std::to_string(g.length), Patterns::Double(1e-6),
                        "Plate length along x." + geometry_units);
      length("Width", g.width, "Plate width along y.");
      length("Wall thickness", g.wall_thickness, "Plate thickness along z.");
      prm.declare_entry("Rib positions", text(g.rib_positions_y), Patterns::List(Patterns::Double(), 1),
                        "y coordinates of the rib centre lines (ribs run along x)." + geometry_units);
      prm.declare_entry("Rib heights", text(g.rib_heights), Patterns::List(Patterns::Double(1e-6), 1),
                        "Height of each rib above the plate." + geometry_units);
      prm.declare_entry("Rib thicknesses", text(g.rib_thicknesses), Patterns::List(Patterns::Double(1e-6), 1),
                        "Thickness of each rib." + geometry_units);
      length("Rib length", g.rib_length, "Length of the ribs, centred in x.");
      length("Boss inset", g.boss_inset, "Distance of the screw-boss axes from the plate edges.");
      length("Boss outer radius", g.boss_outer_radius, "Outer radius of the screw bosses.");
      length("Boss inner radius", g.boss_inner_radius, "Radius of the screw holes.");
      length("Boss height", g.boss_height, "Height of the bosses above the plate.");
      prm.declare_entry("Clip tower centre", text(g.clip_centre), Patterns::Anything(),
                        "x, y of the clip tower's axis (z ignored)." + point_pattern_help + geometry_units);
      length("Clip tower size", g.clip_size, "Outer edge of the square clip tower.");
      length("Clip tower wall", g.clip_wall, "Wall thickness of the clip tower.");
      length("Clip tower height", g.clip_height, "Height of the clip tower above the plate.");
      prm.leave_subsection();
    }

    void parse_ribbed_panel(ParameterHandler &prm, meshing::RibbedPanelGeometry &g)
    {
      prm.enter_subsection("Ribbed panel");
      g.length          = prm.get_double("Length");
      g.width           = prm.get_double("Width");
      g.wall_thickness  = prm.get_double("Wall thickness");
      g.rib_positions_y = parse_doubles(prm.get("Rib positions"));
      g.rib_heights     = parse_doubles(prm.get("Rib heights"));
      g.rib_thicknesses = parse_doubles(prm.get("Rib thicknesses"));
      AssertThrow(g.rib_heights.size() == g.rib_positions_y.size() &&
                    g.rib_thicknesses.size() == g.rib_positions_y.size(),
                  ExcMessage("'Geometry/Ribbed panel': 'Rib positions', 'Rib heights' and 'Rib thicknesses' "
                             "must have the same number of entries (have " + std::to_string(g.rib_positions_y.size()) +
                             ", " + std::to_string(g.rib_heights.size()) + " and " +
                             std::to_string(g.rib_thicknesses.size()) + ")."));
      g.rib_length        = prm.get_double("Rib length");
      g.boss_inset        = prm.get_double("Boss inset");
      g.boss_outer_radius = prm.get_double("Boss outer radius");
      g.boss_inner_radius = prm.get_double("Boss inner radius");
      AssertThrow(g.boss_inner_radius < g.boss_outer_radius,
                  ExcMessage("'Boss inner radius' (" + text(g.boss_inner_radius) +
                             ") must be smaller than 'Boss outer radius' (" + text(g.boss_outer_radius) + ")."));
      g.boss_height = prm.get_double("Boss height");
      g.clip_centre = parse_point(prm.get("Clip tower centre"), "Clip tower centre");
      g.clip_size   = prm.get_double("Clip tower size");
      g.clip_wall   = prm.get_double("Clip tower wall");
      AssertThrow(2. * g.clip_wall < g.clip_size,
                  ExcMessage("'Clip tower wall' (" + text(g.clip_wall) + ") must be less than half of 'Clip tower "
                             "size' (" + text(g.clip_size) + ")."));
      g.clip_height = prm.get_double("Clip tower height");
      prm.leave_subsection();
    }

    // Subsection "Geometry": the part, its length unit and its clamps.
    void declare_geometry(ParameterHandler &prm)
    {
      const SceneParameters scene;
      prm.enter_subsection("Geometry");
      prm.declare_entry("Source", scene.meshing.geometry, Patterns::Anything(),
                        "The part: 'builtin:ribbed_panel' (the panel described in the subsection "
                        "'Ribbed panel'), or a path to a .step/.stp/.iges/.igs/.brep/.geo/.msh file, relative to "
                        "the .prm file's folder. A STEP/IGES file is read in the length unit it declares. Units: "
                        "the geometry's own length unit (see 'Length unit').");
      prm.declare_entry("Length unit", text(scene.length_unit), Patterns::Double(1e-9, 1e9),
                        "Metres per length unit of the geometry and of every length in this file "
                        "(0.001: the geometry is in mm). A STEP/IGES file that declares its unit must be given "
                        "that unit here (1 for metres): a contradicting value is refused. Units: m.");
      prm.declare_entry("Supports", "", Patterns::Anything(),
                        "How the part is held: entries '<selection> : <restraint>' separated by ';' (docs/supports.md). "
                        "Selections: 'surface NAME', 'curve NAME', 'point NAME' (named physical groups), 'box x0 y0 z0 "
                        "x1 y1 z1' (boundary faces inside), 'nodes x0 y0 z0 x1 y1 z1' (boundary FE nodes inside), "
                        "'plane px py pz nx ny nz' (boundary faces in the plane), 'normal nx ny nz ANGLE' (faces whose "
                        "outward normal lies within ANGLE degrees). Restraints: 'clamp', 'fix COMPONENTS' (of x y z, "
                        "or in a local frame: 'fix COMPONENTS in frame e1x e1y e1z e2x e2y e2z', 'fix COMPONENTS in "
                        "cylinder px py pz ax ay az' with components of r t z), 'roller' (the normal component), "
                        "'symmetry' (the normal of a planar selection), 'elastic KN KT' (normal and tangential "
                        "stiffness per area, N/m^3). The rigid-body motions the supports leave free are found and "
                        "handled by inertia relief (they need a negative 'Modes/Shift'). Empty: the clamps of 'Clamp "
                        "groups'. Units: coordinates in the geometry's length unit, stiffness in N/m^3, angles in "
                        "degrees.");
      prm.declare_entry("Clamp groups", "clamp", Patterns::List(Patterns::Anything()),
                        "The older spelling of clamps, used when 'Supports' is empty: names of the physical surfaces "
                        "that are clamped ('a, b' is 'Supports = surface a : clamp; surface b : clamp'). The "
                        "built-in panel names the top faces of its screw bosses 'clamp'. Empty (and no 'Supports'): "
                        "the part is free-floating: its six lowest modes are the rigid-body motions (frequency 0), "
                        "which needs a negative 'Modes/Shift', and static answers are those of inertia relief. "
                        "Units: none.");
      prm.declare_entry("Clamp boxes", "", Patterns::Anything(),
                        "For STEP/IGES/BREP input (which carries no names): boundary faces whose bounding box "
                        "lies inside one of these boxes (within 1e-5 of the part's diagonal) form the physical "
                        "surface 'clamp'; a box that catches no face is refused. Format "
                        "'x0,y0,z0,x1,y1,z1; ...'." + geometry_units);
      declare_ribbed_panel(prm);
      prm.leave_subsection();
    }

    // A path relative to the .prm file's folder; it must exist. Or the one built-in part.
    std::string geometry_source(const std::string &source, const std::string &parameter_file)
    {
      if (source.rfind("builtin:", 0) == 0)
        {
          AssertThrow(source == "builtin:ribbed_panel",
                      ExcMessage("Unknown built-in geometry '" + source + "' in 'Geometry/Source'; the only one is "
                                 "'builtin:ribbed_panel'."));
          return source;
        }
      std::filesystem::path path(source);
      if (path.is_relative())
        path = std::filesystem::path(parameter_file).parent_path() / path;
      const std::string resolved = path.lexically_normal().string();
      AssertThrow(std::filesystem::exists(resolved),
                  ExcMessage("Geometry file '" + resolved + "' (parameter 'Geometry/Source' in " + parameter_file +
                             ") does not exist."));
      return resolved;
    }

    // 'Supports', or when it is empty the older 'Clamp groups' as clamps. Both given: the clamp groups
    // must be the default (unused then) or empty, else the user is shown the one spelling.
    std::vector<Support> supports_of(const std::string &supports, const std::vector<std::string> &clamp_groups)
    {
      if (supports.empty())
        return clamp_group_supports(clamp_groups);
      const bool default_groups = clamp_groups == std::vector<std::string>{"clamp"};
      std::string as_supports;
      for (const auto &group : clamp_groups)
        as_supports += "surface " + group + " : clamp; ";
      AssertThrow(clamp_groups.empty() || default_groups,
                  ExcMessage("'Geometry/Supports' and 'Geometry/Clamp groups' are both set: write the clamps as "
                             "supports, 'Supports = " + as_supports + supports + "', and remove 'Clamp groups'."));
      return parse_supports(supports);
    }

    void parse_geometry(ParameterHandler &prm, SceneParameters &scene)
    {
      prm.enter_subsection("Geometry");
      scene.meshing.geometry = geometry_source(prm.get("Source"), scene.parameter_file);
      scene.length_unit      = prm.get_double("Length unit");
      scene.supports = supports_of(prm.get("Supports"), dealii::Utilities::split_string_list(prm.get("Clamp groups"), ','));
      for (const auto &box_text : dealii::Utilities::split_string_list(prm.get("Clamp boxes"), ';'))
        {
          const auto v = parse_doubles(box_text);
          AssertThrow(v.size() == 6, ExcMessage("'Geometry/Clamp boxes': each box needs 6 numbers, got '" +
                                                box_text + "'."));
          scene.meshing.clamp_boxes.push_back({{{{v[0], v[1], v[2]}}, {{v[3], v[4], v[5]}}}});
        }
      parse_ribbed_panel(prm, scene.meshing.ribbed_panel);
      prm.leave_subsection();
    }

    // Subsection "Meshing": sizes, element degree and quality, beside the "Scenario N" subsections.
    void declare_meshing(ParameterHandler &prm)
    {
      const SceneParameters scene;
      prm.enter_subsection("Meshing");
      prm.declare_entry("Coarse size", text(scene.meshing.coarse_size), Patterns::Double(1e-9),
                        "Element size outside every VOI (the global scenario's size)." + geometry_units);
      prm.declare_entry("Element degree", text(scene.element_degree), Patterns::Integer(1, 2),
                        "Polynomial degree of the tetrahedral elements (FE_SimplexP). Linear tets lock on "
                        "thin walls; 2 is the default. Units: none.");
      prm.declare_entry("Minimum element quality", text(scene.meshing.min_quality), Patterns::Double(0., 1.),
                        "Meshes with a tet of lower quality (gmsh minSICN; <= 0 is inverted) are refused. "
                        "Units: none.");
      prm.declare_entry("Threads", std::to_string(scene.meshing.mesh_threads), Patterns::Integer(0, 64),
                        "gmsh's threads; 0: one per core the process may run on (its CPU affinity, e.g. "
                        "a Slurm task's cores). With more than one, gmsh's 3D mesher (HXT) makes a "
                        "different mesh at every run even of a simple box (one thread: the same), 1 s "
                        "faster on the default scene (docs/performance.md). Units: none.");
      prm.leave_subsection();
    }

    void parse_meshing(ParameterHandler &prm, SceneParameters &scene)
    {
      prm.enter_subsection("Meshing");
      scene.meshing.coarse_size  = prm.get_double("Coarse size");
      scene.element_degree       = prm.get_integer("Element degree");
      scene.meshing.min_quality  = prm.get_double("Minimum element quality");
      scene.meshing.mesh_threads = prm.get_integer("Threads");
      prm.leave_subsection();
    }

    // Subsection "Scenario N": one VOI; an empty name leaves it unused.
    void declare_volume_of_interest(ParameterHandler &prm)
    {
      const meshing::VolumeOfInterest voi;
      prm.declare_entry("Name", voi.name, Patterns::Anything(),
                        "Name of this anticipated contact scenario (its VOI); empty: unused. Units: none.");
      prm.declare_entry("Shape", voi.shape == meshing::VolumeOfInterest::Shape::ball ? "ball" : "box",
                        Patterns::Selection("box|ball"), "Shape of the VOI. Units: none.");
      prm.declare_entry("Box lower corner", text(voi.box_lower), Patterns::Anything(),
                        "Lower corner of a box VOI." + point_pattern_help + geometry_units);
      prm.declare_entry("Box upper corner", text(voi.box_upper), Patterns::Anything(),
                        "Upper corner of a box VOI." + point_pattern_help + geometry_units);
      prm.declare_entry("Ball centre", text(voi.ball_centre), Patterns::Anything(),
                        "Centre of a ball VOI." + point_pattern_help + geometry_units);
      prm.declare_entry("Ball radius", text(voi.ball_radius), Patterns::Double(0.),
                        "Radius of a ball VOI." + geometry_units);
      prm.declare_entry("Fine size", text(voi.fine_size), Patterns::Double(1e-9),
                        "Element size inside the VOI. The default (" + text(voi.fine_size) +
                          ") becomes a quarter of 'Meshing/Coarse size' when that is smaller than it." +
                          geometry_units);
      prm.declare_entry("Transition", text(voi.transition), Patterns::Double(0.),
                        "Distance over which the size grows from the fine to the coarse size." + geometry_units);
    }

    // Reads the current "Scenario N" subsection (named `section` in messages) into a VOI and checks
    // its shape and its size against the coarse size.
    meshing::VolumeOfInterest parse_volume_of_interest(ParameterHandler &prm, const std::string &section,
                                                       const double coarse_size)
    {
      meshing::VolumeOfInterest voi;
      voi.name        = prm.get("Name");
      voi.shape       = prm.get("Shape") == "ball" ? meshing::VolumeOfInterest::Shape::ball :
                                                     meshing::VolumeOfInterest::Shape::box;
      voi.box_lower   = parse_point(prm.get("Box lower corner"), section + "/Box lower corner");
      voi.box_upper   = parse_point(prm.get("Box upper corner"), section + "/Box upper corner");
      voi.ball_centre = parse_point(prm.get("Ball centre"), section + "/Ball centre");
      voi.ball_radius = prm.get_double("Ball radius");
      voi.fine_size   = prm.get_double("Fine size");
      voi.transition  = prm.get_double("Transition");
      // A default nobody wrote must not conflict with a small coarse size (a part in metres).
      if (voi.fine_size == meshing::VolumeOfInterest().fine_size && voi.fine_size > coarse_size)
        voi.fine_size = coarse_size / 4.;
      if (voi.shape == meshing::VolumeOfInterest::Shape::box)
        {
          for (unsigned int d = 0; d < 3; ++d)
            AssertThrow(voi.box_lower[d] < voi.box_upper[d],
                        ExcMessage("'" + section + "' (VOI '" + voi.name + "'): the box's lower corner (" +
                                   text(voi.box_lower) + ") must lie below its upper corner (" + text(voi.box_upper) +
                                   ") in x, y and z."));
        }
      else
        AssertThrow(voi.ball_radius > 0.,
                    ExcMessage("'" + section + "/Ball radius' = " + text(voi.ball_radius) + " must be > 0 for VOI '" +
                               voi.name + "'."));
      AssertThrow(voi.fine_size <= coarse_size,
                  ExcMessage("'" + section + "/Fine size' (" + text(voi.fine_size) +
                             ") is larger than 'Meshing/Coarse size' (" + text(coarse_size) + ")."));
      return voi;
    }

    void declare_scenarios(ParameterHandler &prm)
    {
      for (unsigned int s = 1; s <= max_scenarios; ++s)
        {
          prm.enter_subsection("Scenario " + std::to_string(s));
          declare_volume_of_interest(prm);
          prm.leave_subsection();
        }
    }

    void parse_scenarios(ParameterHandler &prm, SceneParameters &scene)
    {
      std::set<std::string> names;
      for (unsigned int s = 1; s <= max_scenarios; ++s)
        {
          const std::string section = "Scenario " + std::to_string(s);
          prm.enter_subsection(section);
          const std::string name = prm.get("Name");
          if (!name.empty())
            {
              AssertThrow(name != "global" && names.insert(name).second,
                          ExcMessage("'" + section + "/Name' = '" + name +
                                     "' is used twice or is the reserved name 'global'."));
              scene.volumes_of_interest.push_back(parse_volume_of_interest(prm, section, scene.meshing.coarse_size));
            }
          prm.leave_subsection();
        }
    }
  } // namespace
} // namespace modal_haptics
