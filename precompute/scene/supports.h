// Supports: how a part is held. Each support is a selection of its boundary plus what it restrains
// ('Geometry/Supports' in the .prm; docs/supports.md). They become the FE constraints and the
// elastic-foundation stiffness of every modal space, and tell which rigid-body motions stay free.
//
// Selections act on the mesh: surfaces on its boundary faces, curves and points on the FE nodes
// (P2: vertices and edge midpoints) that lie on them. A restraint on a curve or a point therefore
// holds a line or a point of nodes, whose stiffness grows as the mesh is refined around it (the
// exact solution of a line support is singular there): the frequencies converge, the local
// stresses near the line do not.
#pragma once

#include <deal.II/base/point.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>

#include "scene_mesher.h"

#include <mpi.h>

#include <array>
#include <map>
#include <string>
#include <vector>

namespace modal_haptics
{
  struct SupportSelection
  {
    enum class Kind
    {
      surface, // a named physical surface: its boundary faces
      curve,   // a named physical curve: the FE nodes on its segments
      point,   // a named physical point: the FE node at it
      box,     // boundary faces whose three vertices lie in the box
      nodes,   // boundary FE nodes inside the box
      plane,   // boundary faces lying in the plane
      normal   // boundary faces whose outward normal lies within an angle of a direction
    };
    Kind            kind = Kind::surface;
    std::string     name;                  // surface, curve, point
    meshing::Point3 lower{}, upper{};      // box, nodes [geometry units]
    meshing::Point3 point{}, direction{};  // plane (a point, its normal), normal (direction) [geometry units]
    double          angle_degrees = 0.;    // normal

    bool selects_faces() const { return kind == Kind::surface || kind == Kind::box || kind == Kind::plane || kind == Kind::normal; }
    int  named_dimension() const { return kind == Kind::surface ? 2 : kind == Kind::curve ? 1 : 0; }
  };

  struct SupportRestraint
  {
    enum class Kind
    {
      clamp,    // every component
      fix,      // some components of a frame
      roller,   // the normal component (the selected faces' normals averaged at each node)
      symmetry, // the normal component of a planar selection
      elastic   // an elastic foundation: normal and tangential stiffness per area
    };
    enum class Frame
    {
      global,    // x, y, z
      cartesian, // x = e1, y = e2 (made orthogonal to e1), z = e1 x e2
      cylinder   // r, t, z about the axis through 'origin' along 'axis'
    };
    Kind                 kind  = Kind::clamp;
    Frame                frame = Frame::global;
    std::array<bool, 3>  components{};       // fix: which of the frame's (x, y, z) or (r, t, z)
    dealii::Tensor<1, 3> e1, e2;             // cartesian frame
    dealii::Point<3>     origin;             // cylinder [geometry units]
    dealii::Tensor<1, 3> axis;               // cylinder
    double               normal_stiffness     = 0.; // elastic [N/m^3]
    double               tangential_stiffness = 0.; // elastic [N/m^3]
  };

  struct Support
  {
    std::string      text;  // as written, for messages: "support 2 ('curve edges : fix z')"
    unsigned int     index = 0;
    SupportSelection selection;
    SupportRestraint restraint;

    std::string label() const { return "support " + std::to_string(index + 1) + " ('" + text + "')"; }
  };

  // Parses 'Geometry/Supports': entries separated by ';', each '<selection> : <restraint>'.
  // Throws ExcMessage naming the entry and what is wrong with it.
  std::vector<Support> parse_supports(const std::string &text);

  // The old spelling 'Clamp groups = a, b' as supports ('surface a : clamp; surface b : clamp').
  std::vector<Support> clamp_group_supports(const std::vector<std::string> &groups);

  // The rigid-body motions a set of supports leaves free, as combinations of the six motions about a
  // centre: translations along x, y, z, then rotations about the axes through the centre, a rotation
  // counted per unit angle times 'length_scale' (so that the coefficients of both kinds compare).
  struct FreeMotions
  {
    dealii::Point<3>                   centre;
    double                             length_scale = 1.;
    std::vector<std::array<double, 6>> motions; // orthonormal coefficient vectors
    // Motion m at x.
    dealii::Tensor<1, 3> displacement(unsigned int m, const dealii::Point<3> &x) const;
    std::string          describe() const; // "translation along x, rotation about z"
  };

  // The directions a restraint holds at a point x [m] of its selection whose outward normal there is
  // 'normal': rigidly (clamp, fix, roller, symmetry) and, for an elastic foundation, its stiff ones.
  // 'tolerance' [m]: a point this close to a cylinder's axis holds its cross-section.
  std::vector<dealii::Tensor<1, 3>> held_directions(const SupportRestraint &r, const dealii::Point<3> &x,
                                                    const dealii::Tensor<1, 3> &normal, double length_unit,
                                                    double tolerance);

  // What the supports make of a space's FE space: the constraints (added to the caller's, which
  // the caller closes), the faces of elastic supports (assembled into K), what each support caught,
  // and the directions held at the nodes, from which follow the motions left free.
  struct ElasticFace
  {
    dealii::DoFHandler<3>::active_cell_iterator cell;
    unsigned int                                face;
    double                                      normal_stiffness, tangential_stiffness; // [N/m^3]
  };
  struct SupportReport // what each support caught, summed over the processes
  {
    unsigned int n_faces = 0, n_nodes = 0;
    double       area    = 0.; // [m^2]
  };
  struct ResolvedSupports
  {
    std::vector<ElasticFace>   elastic_faces; // of this process's cells
    std::vector<SupportReport> reports;       // one per support
    unsigned int               n_restrained_nodes = 0; // with at least one held direction (constraint)
    double                     part_diagonal      = 0.; // of the boundary's bounding box [m]
    // Every direction held at a node this process owns, rigidly or elastically.
    std::vector<std::pair<dealii::Point<3>, dealii::Tensor<1, 3>>> held;

    // The rigid-body motions that move no held direction, about 'centre' (collective over 'comm').
    FreeMotions free_motions(const dealii::Point<3> &centre, MPI_Comm comm = MPI_COMM_SELF) const;
    // "support 1 ('...'): 12 faces, 3.1e-4 m^2, 40 nodes" per support.
    std::string summary(const std::vector<Support> &supports) const;
  };

  // Resolves the supports on a space's mesh and adds their constraints (for the DoFs of the cells this
  // process owns or ghosts). 'group_file' is the mesh file the named curves and points are read from;
  // 'surfaces' maps the mesh's physical surface names to boundary ids. A selection that catches
  // nothing, a missing name, a non-planar symmetry are user errors naming the support. 'length_unit'
  // converts the supports' lengths to metres (the mesh is in metres).
  ResolvedSupports resolve_supports(const std::vector<Support> &supports, const std::string &group_file,
                                    const std::map<std::string, int> &surfaces, double length_unit,
                                    const dealii::Mapping<3> &mapping,
                                    const dealii::DoFHandler<3> &dof_handler,
                                    dealii::AffineConstraints<double> &constraints, MPI_Comm comm = MPI_COMM_SELF);

  // Replaces every weight on a constrained DoF by its share on the DoFs it is constrained to (C^T w):
  // a load so condensed acts on the constrained system, a reading so condensed gives the value of
  // the constrained field whether or not the field's constrained entries were filled in.
  void condense_weights(const dealii::AffineConstraints<double> &constraints,
                        std::vector<std::pair<dealii::types::global_dof_index, double>> &weights);

  // True when some constraint couples DoFs (a roller, a local frame): the constrained entries of a
  // solution are then not zero and must be filled in (AffineConstraints::distribute) for output.
  bool has_coupling_constraints(const dealii::AffineConstraints<double> &constraints);
} // namespace modal_haptics
