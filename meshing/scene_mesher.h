// The meshing stage: gmsh (C++ API, OCC kernel) turns a scene's geometry into one graded tet mesh
// per scenario and one display/contact triangle surface per scene.
//
// This header is plain C++17 + the standard library so that the precompute (deal.II) and the tests
// can use it without seeing gmsh. Every length here is in the geometry's own unit (the built-in
// ribbed panel is in millimetres); the precompute converts to metres.
#pragma once

#include <array>
#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace modal_haptics::meshing
{
  using Point3 = std::array<double, 3>;

  // A user error in meshing (missing file, empty group, VOI outside the part, bad mesh quality).
  // The message names the file, the group or the value.
  class MeshingError : public std::runtime_error
  {
  public:
    using std::runtime_error::runtime_error;
  };

  // The built-in default part: an injection-moulded panel with ribs on its back, screw bosses
  // at its mounting points and a clip tower. Units: mm.
  struct RibbedPanelGeometry
  {
    double length          = 300.; // along x [mm]
    double width           = 200.; // along y [mm]
    double wall_thickness  = 3.;   // plate thickness, plate spans z in [0, wall_thickness] [mm]
    // Ribs run along x on top of the plate (z > wall_thickness), centred at rib_positions_y.
    std::vector<double> rib_positions_y = {-50., 0., 50.}; // rib centre lines, y [mm] (plate centred at 0)
    std::vector<double> rib_heights     = {8., 14., 20.};  // above the plate top [mm]
    std::vector<double> rib_thicknesses = {1.5, 2., 1.8};  // [mm]
    double rib_length      = 260.; // ribs centred in x [mm]
    // Screw bosses (hollow cylinders) at the four mounting points, standing on the plate top.
    double boss_inset       = 20.;  // distance of boss axes from the plate edges [mm]
    double boss_outer_radius = 5.;  // [mm]
    double boss_inner_radius = 2.;  // screw hole radius [mm]
    double boss_height      = 12.;  // above the plate top [mm]
    // A clip tower: a hollow square tower between ribs, for a snap-fit clip.
    Point3 clip_centre = {{60., 25., 0.}}; // x, y of the tower axis [mm] (z ignored)
    double clip_size   = 10.;   // outer edge [mm]
    double clip_wall   = 1.5;   // wall thickness [mm]
    double clip_height = 15.;   // above the plate top [mm]
  };
  // The plate is centred on the origin in x and y: x in [-length/2, length/2], y in [-width/2, width/2].
  // Named physical groups written by the built-in geometry:
  //   volume  "part"
  //   surface "clamp"  the top annular faces of the bosses (where the screw heads hold the part)
  //   surface "free"   every other boundary face

  // A Volume Of Interest: where contact is anticipated, meshed densely in its own scenario.
  struct VolumeOfInterest
  {
    enum class Shape { box, ball };
    std::string name;              // scenario name, e.g. "rib_a"
    Shape  shape = Shape::box;
    Point3 box_lower = {{0., 0., 0.}};  // box corner [unit]
    Point3 box_upper = {{0., 0., 0.}};  // box corner [unit]
    Point3 ball_centre = {{0., 0., 0.}}; // [unit]
    double ball_radius = 0.;          // [unit]
    double fine_size   = 1.5;         // element size inside [unit]
    double transition  = 15.;         // distance over which the size grows to the coarse size [unit]

    bool contains(const Point3 &p, double tolerance = 0.) const;
  };

  struct MeshingSettings
  {
    // "builtin:ribbed_panel", or a path to a .step/.stp/.brep/.geo file (meshed here)
    // or to a .msh file (used as it is, for the global scenario only: it cannot be re-graded).
    std::string geometry = "builtin:ribbed_panel";
    RibbedPanelGeometry ribbed_panel; // used with "builtin:ribbed_panel"
    double coarse_size = 6.;          // element size outside every VOI [unit]
    // For STEP/IGES/BREP input, which has no names: boundary faces whose bounding box lies inside one
    // of these boxes (widened by 1e-5 of the part's bounding-box diagonal + 2e-7, OpenCASCADE's own
    // padding) form the physical surface "clamp". A box that catches no face is an error.
    std::vector<std::array<Point3, 2>> clamp_boxes;
    int    mesh_threads = 1;          // gmsh's threads; 0: one per core this process may run on
    // The VOIs' meshes in child processes (fork) beside this one's global mesh and display surface,
    // where gmsh runs on one thread and the process may use more than one core. Set by a caller
    // that may fork: modal-precompute when no MPI launcher started it.
    bool   mesh_vois_beside = false;
    double min_quality  = 0.01;       // minimum acceptable element quality (gmsh minSICN); below: error
  };

  struct MeshStatistics
  {
    std::size_t n_nodes = 0;
    std::size_t n_tets = 0;
    double min_quality = 0.;  // gmsh minSICN over all tets (1 = regular, <= 0 = inverted/degenerate)
    double max_quality = 0.;
    double mean_quality = 0.;
    double seconds = 0.;      // wall time spent meshing (0 when reused from the cache)
    bool   reused = false;    // true when an up-to-date mesh was found and reused
    bool   made_in_child_process = false; // made beside this process (MeshingSettings::mesh_vois_beside)
  };

  struct ScenarioMesh
  {
    std::string name;                      // "global" or the VOI's name
    std::string msh_file;                  // path of the written mesh (MSH 4.1 ASCII, linear tets)
    std::string cache_key;                 // hash of every input the mesh depends on (mesh_<name>.key)
    std::map<std::string, int> physical_surfaces; // name -> physical tag (tags >= 1), as in the file
    std::map<std::string, int> physical_volumes;  // name -> physical tag
    MeshStatistics statistics;
  };

  // The display/contact surface: the part's whole boundary as one triangle mesh, fine wherever any
  // VOI is fine (size field = min over every VOI's field and the coarse size).
  struct DisplaySurface
  {
    std::vector<Point3> vertices;                   // [unit]
    std::vector<std::array<unsigned int, 3>> triangles; // vertex indices, outward orientation
    std::string msh_file;                            // where it was written
    std::string cache_key;                           // hash of its inputs (display_surface.key)
    MeshStatistics statistics;                       // n_tets = 0, n_nodes = vertices.size()
  };

  // The meshing stage's output, what the precompute consumes: one mesh per scenario and the display
  // surface, each with the file it lies in and the cache key of the inputs it was made from.
  struct SceneMeshes
  {
    std::vector<ScenarioMesh> scenarios; // scenarios[0] is "global", then one per VOI in order
    DisplaySurface display_surface;
  };

  // Meshes the global scenario (coarse everywhere) and one scenario per VOI (coarse, graded down
  // to the VOI's fine size), plus the display surface, into output_directory as
  // mesh_<name>.msh and display_surface.msh. A mesh whose inputs (settings, VOI, geometry file
  // content) did not change since it was written is reused: its key lies beside it in
  // mesh_<name>.key. Writes each file to a temporary name first, then renames.
  // Throws MeshingError on user errors: missing/unreadable geometry, a geometry gmsh cannot mesh,
  // a VOI that does not intersect the part, tets below min_quality (inverted or degenerate).
  // With reuse_only, every mesh must be in the cache (a run that must not mesh: gmsh is not
  // bit-reproducible, so jobs that share meshes must not make their own); else MeshingError.
  SceneMeshes mesh_scene(const MeshingSettings &settings,
                         const std::vector<VolumeOfInterest> &volumes_of_interest,
                         const std::string &output_directory,
                         bool verbose = true,
                         bool reuse_only = false);

  // gmsh's own lines (its progress and information: about 200 for a small STEP part) are off unless
  // shown (modal-precompute --gmsh-verbose); its warnings and errors are printed whenever the
  // mesher's lines are.
  void show_gmsh_log(bool shown);

  // The length unit a STEP (LENGTH_UNIT entity) or IGES (global section's units flag) file declares.
  // Empty (metres = 0) for a file that declares none, and for BREP, .geo and .msh, which carry no unit.
  // Throws MeshingError for a unit OpenCASCADE cannot convert. The mesher reads a STEP/IGES file in
  // its declared unit (gmsh 4.8's OpenCASCADE would otherwise convert it to millimetres).
  struct DeclaredUnit
  {
    std::string name;     // "metre", "millimetre", "inch", ...
    std::string occ_code; // gmsh's Geometry.OCCTargetUnit ("M", "MM", "INCH", ...)
    double      metres = 0.; // metres per unit
  };
  DeclaredUnit declared_length_unit(const std::string &file);

  // What a selection caught: its boundary faces and their area.
  struct SelectionReport
  {
    std::string name;       // "Clamp group 'clamp'", "Clamp boxes entry 1 (...)"
    std::size_t n_faces = 0;      // entities caught: faces, or the curves or points of a named group
    std::string entity  = "face"; // what n_faces counts: "face", "curve", "point"
    double      area    = 0.; // [unit^2]; 0 for a .msh input (no geometry)
    // Points on what was caught (within a box or a plane) and the outward normal there [unit]: from
    // them --validate predicts the rigid-body motions the supports leave free. None for a .msh.
    std::vector<std::array<Point3, 2>> samples;
  };

  // A support's box, plane or normal direction, checked against the geometry before meshing
  // (supports select mesh faces and nodes at run time; here: whether any CAD surface's bounding box
  // meets the box or the plane, which CAD surfaces face the direction).
  struct RegionSelection
  {
    enum class Kind { box, plane, normal };
    std::string label;             // "support 2 ('box 0 0 0 1 1 1 : clamp')"
    Kind        kind = Kind::box;
    Point3      lower{}, upper{};  // box [unit]
    Point3      point{}, normal{}; // plane [unit]; normal: the direction
    double      angle_degrees = 0.; // normal: the largest angle of a surface's outward normal to it
  };

  // The geometry as loaded (not meshed), for --validate and the start of every run.
  struct GeometryReport
  {
    DeclaredUnit unit;            // what the file declares (empty: 'Length unit' applies)
    Point3       lower{}, upper{}; // bounding box [unit]
    double       volume = 0.;     // [unit^3]; 0 when unknown (a .geo of gmsh's built-in kernel)
    std::vector<SelectionReport> named_groups; // one per named group, in order (n_faces: its entities)
    std::vector<SelectionReport> clamp_boxes;  // one per 'Clamp boxes' entry (STEP/IGES/BREP only)
    // Per VOI, the boundary faces whose bounding box meets the VOI's (none for a .msh input, which
    // takes no VOI); their whole areas, so an upper bound of the surface inside. The mesh vertices
    // inside a VOI are counted in the meshing log.
    std::vector<SelectionReport> volumes_of_interest;
    std::vector<SelectionReport> regions; // one per RegionSelection: the faces whose bounding box meets it
    // Each physical group of a .geo that holds nothing, in words ("the physical surface 'wall' holds
    // no surface (...)"): left out of the model and the meshes, for the caller to warn about (a
    // selection that names one is refused).
    std::vector<std::string> empty_groups;
  };

  // Loads the geometry without meshing it and checks, throwing MeshingError that names the culprit:
  // the settings and VOIs (a VOI outside the part's bounding box), the file's declared length unit
  // against 'length_unit' (metres per unit, refused when they differ), every clamp box (one that
  // catches no boundary face is refused, naming the nearest face), every named group (dimension, name)
  // (a physical surface of the model; one the file declares empty is refused as empty). Seconds, not
  // minutes: nothing is meshed (a .msh is read).
  GeometryReport inspect_geometry(const MeshingSettings &settings,
                                  const std::vector<VolumeOfInterest> &volumes_of_interest,
                                  const std::vector<std::pair<int, std::string>> &named_groups,
                                  const std::vector<RegionSelection> &regions, double length_unit);

  // Reads the $PhysicalNames of a MSH file: dimension -> (name -> tag).
  std::map<int, std::map<std::string, int>> read_physical_names(const std::string &msh_file);

  // The mesh of a named physical curve (dim 1) or point (dim 0) of a MSH file: its nodes [unit] and,
  // for a curve, its linear segments (indices into nodes). Throws MeshingError naming the file and the
  // groups of that dimension it has when there is none of that name.
  struct GroupMesh
  {
    std::vector<Point3>                      nodes;
    std::vector<std::array<unsigned int, 2>> segments;
  };
  GroupMesh read_physical_group(const std::string &msh_file, int dim, const std::string &name);

  // Checks a MSH file's tets (for user-supplied .msh input): throws MeshingError naming the file
  // and the first bad element when a tet is inverted or degenerate.
  MeshStatistics check_mesh_quality(const std::string &msh_file, double min_quality);
} // namespace modal_haptics::meshing
