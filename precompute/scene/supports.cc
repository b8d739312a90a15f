// Supports on a space's mesh (supports.h): each selection resolved on the boundary faces and FE
// nodes, each node's held directions made into constraints, the elastic faces kept for assembly.
#include "scene/supports.h"

#include "scene/linear_tet.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/utilities.h>
#include <deal.II/fe/fe.h>
#include <deal.II/fe/mapping_fe.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <unordered_map>

namespace modal_haptics
{
  using namespace dealii;

  // ---- Resolution on a mesh --------------------------------------------------------------------
  namespace
  {
    // An FE node on the boundary: its point and the DoFs of its three components.
    struct Node
    {
      Point<3>                                  x;
      std::array<types::global_dof_index, 3>    dofs;
      std::vector<Tensor<1, 3>>                 restrained; // directions, accumulated over the supports
    };

    struct BoundaryFace
    {
      DoFHandler<3>::active_cell_iterator cell;
      unsigned int                        face;
      types::boundary_id                  boundary_id;
      std::array<Point<3>, 3>             vertices;
      Tensor<1, 3>                        normal; // outward, unit
      double                              area;
      std::vector<unsigned int>           nodes; // indices into the node list
      bool                                owned;
    };

    // Every boundary face of the cells this process owns or ghosts, with its FE nodes.
    class BoundaryView
    {
    public:
      BoundaryView(const Mapping<3> &mapping, const DoFHandler<3> &dof_handler)
      {
        const auto &fe = dof_handler.get_fe();
        AssertThrow(fe.n_base_elements() == 1 && fe.n_components() == 3,
                    ExcMessage("Supports: one scalar element for the three displacement components is expected."));
        std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
        std::vector<Point<3>>                node_points;
        for (const auto &cell : dof_handler.active_cell_iterators())
          if (!cell->is_artificial() && cell->at_boundary())
            {
              cell->get_dof_indices(dofs);
              place_nodes(mapping, cell, fe, node_points);
              for (const auto f : cell->face_indices())
                if (cell->face(f)->at_boundary())
                  faces.push_back(make_face(cell, f, dofs, node_points, fe));
            }
      }

      std::vector<BoundaryFace> faces;
      std::vector<Node>         nodes;

    private:
      // Where the cell's FE nodes are (one point per base function, shared by its three components).
      // A tet of linear geometry (a degree-1 MappingFE) maps them from its vertices as the mapping
      // would (point_in_linear_tet), at a fraction of the cost of asking the mapping point by point
      // (which evaluates the barycentric polynomials for every node of every boundary cell).
      static void place_nodes(const Mapping<3> &mapping, const DoFHandler<3>::active_cell_iterator &cell,
                              const FiniteElement<3> &fe, std::vector<Point<3>> &points)
      {
        const auto &unit_points = fe.base_element(0).get_unit_support_points();
        points.resize(unit_points.size());
        const auto *linear = dynamic_cast<const MappingFE<3> *>(&mapping);
        const bool  affine = linear != nullptr && linear->get_degree() == 1 && cell->reference_cell().is_simplex();
        for (std::size_t j = 0; j < unit_points.size(); ++j)
          points[j] = affine ? point_in_linear_tet(cell, unit_points[j]) :
                               mapping.transform_unit_to_real_cell(cell, unit_points[j]);
      }

      BoundaryFace make_face(const DoFHandler<3>::active_cell_iterator &cell, const unsigned int f,
                             const std::vector<types::global_dof_index> &dofs, const std::vector<Point<3>> &node_points,
                             const FiniteElement<3> &fe)
      {
        BoundaryFace face{cell, f, cell->face(f)->boundary_id(), {}, {}, 0., {}, cell->is_locally_owned()};
        for (unsigned int v = 0; v < 3; ++v)
          face.vertices[v] = cell->face(f)->vertex(v);
        Tensor<1, 3> n = cross_product_3d(face.vertices[1] - face.vertices[0], face.vertices[2] - face.vertices[0]);
        face.area      = n.norm() / 2.;
        n /= n.norm();
        if ((cell->center() - face.vertices[0]) * n > 0.) // the cell's centre lies inside
          n = -n;
        face.normal         = n;
        const double height = std::sqrt(face.area);
        // The cell's nodes in the face's plane (support points of a linear-geometry tet). A node is
        // shared by the faces that hold it: found again through any of its DoFs.
        std::map<unsigned int, unsigned int> node_of_base_index;
        for (unsigned int i = 0; i < dofs.size(); ++i)
          {
            const auto [component, base_index] = fe.system_to_component_index(i);
            const Point<3> &x                  = node_points[base_index];
            if (std::abs((x - face.vertices[0]) * n) > 1e-9 * height)
              continue;
            unsigned int node;
            if (const auto known = index_of_dof.find(dofs[i]); known != index_of_dof.end())
              node = known->second;
            else if (const auto same = node_of_base_index.find(base_index); same != node_of_base_index.end())
              node = same->second;
            else
              {
                node = nodes.size();
                nodes.push_back({x, {}, {}});
              }
            node_of_base_index[base_index] = node;
            index_of_dof[dofs[i]]          = node;
            nodes[node].dofs[component]    = dofs[i];
          }
        for (const auto &[base_index, node] : node_of_base_index)
          face.nodes.push_back(node);
        return face;
      }

    private:
      std::unordered_map<types::global_dof_index, unsigned int> index_of_dof;
    };
  } // namespace

  // ---- Resolution ------------------------------------------------------------------------------
  namespace
  {
    using Kind = SupportSelection::Kind;

    Point<3> scaled(const meshing::Point3 &p, const double length_unit)
    {
      return Point<3>(p[0] * length_unit, p[1] * length_unit, p[2] * length_unit);
    }

    std::string readable(const Point<3> &x, const double length_unit)
    {
      std::ostringstream out;
      out << std::setprecision(6) << "(" << x[0] / length_unit << ", " << x[1] / length_unit << ", "
          << x[2] / length_unit << ")";
      return out.str();
    }

    // The nearest of some candidates over every process: its distance and where it is.
    std::pair<double, Point<3>> nearest_over_processes(const std::vector<std::pair<double, Point<3>>> &local,
                                                       const MPI_Comm comm)
    {
      std::pair<double, Point<3>> best{std::numeric_limits<double>::infinity(), Point<3>()};
      for (const auto &candidate : local)
        if (candidate.first < best.first)
          best = candidate;
      for (const auto &candidate : Utilities::MPI::all_gather(comm, best))
        if (candidate.first < best.first)
          best = candidate;
      return best;
    }

    class Resolver
    {
    public:
      Resolver(const BoundaryView &boundary, const std::string &group_file, const std::map<std::string, int> &surfaces,
               const double length_unit, const unsigned int degree, const MPI_Comm comm)
        : boundary(boundary)
        , group_file(group_file)
        , surfaces(surfaces)
        , length_unit(length_unit)
        , degree(degree)
        , comm(comm)
      {
        Point<3> lower(std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
        Point<3> upper = -1. * lower;
        for (const auto &face : boundary.faces)
          for (const auto &v : face.vertices)
            for (unsigned int d = 0; d < 3; ++d)
              lower[d] = std::min(lower[d], v[d]), upper[d] = std::max(upper[d], v[d]);
        for (unsigned int d = 0; d < 3; ++d)
          lower[d] = Utilities::MPI::min(lower[d], comm), upper[d] = Utilities::MPI::max(upper[d], comm);
        diagonal  = (upper - lower).norm();
        tolerance = 1e-5 * diagonal;
      }

      double diagonal = 0., tolerance = 0.; // [m]

      // The boundary faces a face selection catches (of this process's cells).
      std::vector<unsigned int> faces_of(const Support &support) const
      {
        const auto &s = support.selection;
        std::function<bool(const BoundaryFace &)> caught;
        switch (s.kind)
          {
            case Kind::surface:
              {
                const auto tag = types::boundary_id(surface_tag(support));
                caught        = [tag](const BoundaryFace &f) { return f.boundary_id == tag; };
                break;
              }
            case Kind::box:
              caught = [&](const BoundaryFace &f) {
                return std::all_of(f.vertices.begin(), f.vertices.end(), [&](const Point<3> &v) { return in_box(s, v); });
              };
              break;
            case Kind::plane:
              caught = [&](const BoundaryFace &f) {
                return std::all_of(f.vertices.begin(), f.vertices.end(),
                                   [&](const Point<3> &v) { return std::abs(plane_distance(s, v)) <= tolerance; });
              };
              break;
            case Kind::normal:
              caught = [&](const BoundaryFace &f) { return f.normal * direction(s) >= min_cosine(s); };
              break;
            default:
              Assert(false, ExcInternalError());
          }
        std::vector<unsigned int> caught_faces;
        for (unsigned int i = 0; i < boundary.faces.size(); ++i)
          if (caught(boundary.faces[i]))
            caught_faces.push_back(i);
        return caught_faces;
      }

      // The boundary nodes a node selection (curve, point, nodes) catches.
      std::vector<unsigned int> nodes_of(const Support &support) const
      {
        const auto               &s = support.selection;
        std::vector<unsigned int> caught;
        if (s.kind == Kind::nodes)
          {
            for (unsigned int i = 0; i < boundary.nodes.size(); ++i)
              if (in_box(s, boundary.nodes[i].x))
                caught.push_back(i);
            return caught;
          }
        std::vector<Point<3>> targets = group_points(support);
        std::sort(targets.begin(), targets.end(), [](const Point<3> &a, const Point<3> &b) { return a[0] < b[0]; });
        for (unsigned int i = 0; i < boundary.nodes.size(); ++i)
          {
            const Point<3> &x     = boundary.nodes[i].x;
            auto            first = std::lower_bound(targets.begin(), targets.end(), x[0] - tolerance,
                                          [](const Point<3> &p, double value) { return p[0] < value; });
            for (; first != targets.end() && first->operator[](0) <= x[0] + tolerance; ++first)
              if (first->distance(x) <= tolerance)
                {
                  caught.push_back(i);
                  break;
                }
          }
        return caught;
      }

      // A selection that caught nothing anywhere: the message names it and what lies nearest.
      [[noreturn]] void refuse_empty(const Support &support) const
      {
        const auto                              &s = support.selection;
        std::vector<std::pair<double, Point<3>>> local;
        std::string                              what = "boundary face (centre)";
        if (s.kind == Kind::normal)
          {
            for (const auto &face : boundary.faces)
              local.emplace_back(std::acos(std::clamp(face.normal * direction(s), -1., 1.)) * 180. / M_PI,
                                 centre(face));
            const auto [angle, where] = nearest_over_processes(local, comm);
            AssertThrow(false, ExcMessage("The selection of " + support.label() + " catches no boundary face: the "
                                          "closest normal is " + std::to_string(angle) + " degrees from the direction, "
                                          "at the face centred at " + readable(where, length_unit) + "."));
          }
        const Point<3> target = s.kind == Kind::plane ? scaled(s.point, length_unit) :
                                (s.kind == Kind::box || s.kind == Kind::nodes) ?
                                                        scaled(s.lower, length_unit) + 0.5 * (scaled(s.upper, length_unit) - scaled(s.lower, length_unit)) :
                                                        group_points(support).front();
        if (s.selects_faces())
          for (const auto &face : boundary.faces)
            local.emplace_back(s.kind == Kind::plane ? std::abs(plane_distance(s, centre(face))) : centre(face).distance(target),
                               centre(face));
        else
          {
            what = "boundary FE node";
            for (const auto &node : boundary.nodes)
              local.emplace_back(node.x.distance(target), node.x);
          }
        const auto [distance, where] = nearest_over_processes(local, comm);
        AssertThrow(false, ExcMessage("The selection of " + support.label() + " catches no " +
                                      (s.selects_faces() ? "boundary face" : "boundary FE node") + ": the nearest " + what +
                                      " is at " + readable(where, length_unit) + ", " + std::to_string(distance / length_unit) +
                                      " geometry units away (lengths in 'Geometry/Supports' are in geometry units)."));
      }

      Tensor<1, 3> direction(const SupportSelection &s) const
      {
        const Tensor<1, 3> d({s.direction[0], s.direction[1], s.direction[2]});
        return d / d.norm();
      }

    private:
      int surface_tag(const Support &support) const
      {
        const auto it = surfaces.find(support.selection.name);
        std::string known;
        for (const auto &[name, tag] : surfaces)
          known += (known.empty() ? "'" : ", '") + name + "'";
        AssertThrow(it != surfaces.end(), ExcMessage("The selection of " + support.label() + ": the mesh '" + group_file +
                                                     "' has no physical surface '" + support.selection.name +
                                                     "' (its physical surfaces: " + (known.empty() ? "none" : known) + ")."));
        return it->second;
      }

      // A named curve's or point's FE node positions [m]: its mesh nodes and, for P2, the midpoints of
      // the curve's segments.
      std::vector<Point<3>> group_points(const Support &support) const
      {
        const auto &s = support.selection;
        meshing::GroupMesh group;
        try
          {
            group = meshing::read_physical_group(group_file, s.named_dimension(), s.name);
          }
        catch (const meshing::MeshingError &e)
          {
            AssertThrow(false, ExcMessage("The selection of " + support.label() + ": " + e.what() + "."));
          }
        std::vector<Point<3>> points;
        for (const auto &node : group.nodes)
          points.push_back(scaled(node, length_unit));
        if (degree == 2)
          for (const auto &[a, b] : group.segments)
            points.push_back(scaled(group.nodes[a], length_unit) + 0.5 * (scaled(group.nodes[b], length_unit) - scaled(group.nodes[a], length_unit)));
        AssertThrow(!points.empty(), ExcMessage("The selection of " + support.label() + ": the group has no mesh node."));
        return points;
      }

      bool in_box(const SupportSelection &s, const Point<3> &x) const
      {
        for (unsigned int d = 0; d < 3; ++d)
          if (x[d] < s.lower[d] * length_unit - tolerance || x[d] > s.upper[d] * length_unit + tolerance)
            return false;
        return true;
      }
      double plane_distance(const SupportSelection &s, const Point<3> &x) const
      {
        return (x - scaled(s.point, length_unit)) * direction(s);
      }
      double min_cosine(const SupportSelection &s) const
      {
        return std::cos(std::max(s.angle_degrees, 1e-4) * M_PI / 180.);
      }
      static Point<3> centre(const BoundaryFace &f)
      {
        return Point<3>((f.vertices[0] + f.vertices[1] + f.vertices[2]) / 3.);
      }

      const BoundaryView               &boundary;
      const std::string                 group_file;
      const std::map<std::string, int> &surfaces;
      const double                      length_unit;
      const unsigned int                degree;
      const MPI_Comm                    comm;
    };

    // The directions a restraint holds at one node of its selection.
    std::vector<Tensor<1, 3>> restrained_directions(const SupportRestraint &r, const Point<3> &x,
                                                    const Tensor<1, 3> &normal, const double length_unit,
                                                    const double tolerance)
    {
      using R = SupportRestraint;
      const Tensor<1, 3> ex({1., 0., 0.}), ey({0., 1., 0.}), ez({0., 0., 1.});
      switch (r.kind)
        {
          case R::Kind::clamp:
            return {ex, ey, ez};
          case R::Kind::roller:
          case R::Kind::symmetry:
            return {normal};
          case R::Kind::elastic:
            return {};
          case R::Kind::fix:
            break;
        }
      std::array<Tensor<1, 3>, 3> axes = {{ex, ey, ez}};
      if (r.frame == R::Frame::cartesian)
        axes = {{r.e1, r.e2, cross_product_3d(r.e1, r.e2)}};
      else if (r.frame == R::Frame::cylinder)
        {
          const Tensor<1, 3> d      = x - r.origin * length_unit;
          Tensor<1, 3>       radial = d - (d * r.axis) * r.axis;
          if (radial.norm() <= tolerance) // on the axis: r and t are both the plane across it
            {
              radial = cross_product_3d(r.axis, std::abs(r.axis[0]) < 0.9 ? ex : ey);
              radial /= radial.norm();
              std::vector<Tensor<1, 3>> held;
              if (r.components[0] || r.components[1])
                held = {radial, cross_product_3d(r.axis, radial)};
              if (r.components[2])
                held.push_back(r.axis);
              return held;
            }
          radial /= radial.norm();
          axes = {{radial, cross_product_3d(r.axis, radial), r.axis}};
        }
      std::vector<Tensor<1, 3>> held;
      for (unsigned int c = 0; c < 3; ++c)
        if (r.components[c])
          held.push_back(axes[c]);
      return held;
    }

    // An orthonormal basis of the directions' span (Gram-Schmidt; nearly parallel ones merge).
    std::vector<Tensor<1, 3>> orthonormal_span(const std::vector<Tensor<1, 3>> &directions)
    {
      std::vector<Tensor<1, 3>> basis;
      for (Tensor<1, 3> d : directions)
        {
          for (const auto &b : basis)
            d -= (d * b) * b;
          if (d.norm() > 1e-6 && basis.size() < 3)
            basis.push_back(d / d.norm());
        }
      return basis;
    }

    // u . d = 0 for each held direction d of a node, as constraints on its three DoFs: all three
    // zero; two held: the node moves along the free direction f only (two components follow the
    // largest one of f); one held: the largest component of d follows the others.
    void add_node_constraints(const Node &node, const std::vector<Tensor<1, 3>> &held,
                              AffineConstraints<double> &constraints)
    {
      const auto largest = [](const Tensor<1, 3> &v) {
        unsigned int p = 0;
        for (unsigned int c = 1; c < 3; ++c)
          if (std::abs(v[c]) > std::abs(v[p]))
            p = c;
        return p;
      };
      const auto constrain = [&](const unsigned int c, const unsigned int on, const double factor) {
        const auto dof = node.dofs[c];
        if (!constraints.can_store_line(dof) || constraints.is_constrained(dof))
          return;
        constraints.add_line(dof);
        if (std::abs(factor) > 1e-12)
          constraints.add_entry(dof, node.dofs[on], factor);
      };
      if (held.size() == 3)
        for (unsigned int c = 0; c < 3; ++c)
          constrain(c, c, 0.);
      else if (held.size() == 2)
        {
          Tensor<1, 3> f = cross_product_3d(held[0], held[1]);
          const auto   p = largest(f);
          for (unsigned int c = 0; c < 3; ++c)
            if (c != p)
              constrain(c, p, f[c] / f[p]);
        }
      else if (held.size() == 1)
        {
          const auto &d = held[0];
          const auto  p = largest(d);
          const auto  dof = node.dofs[p];
          if (!constraints.can_store_line(dof) || constraints.is_constrained(dof))
            return;
          constraints.add_line(dof);
          for (unsigned int c = 0; c < 3; ++c)
            if (c != p && std::abs(d[c] / d[p]) > 1e-12)
              constraints.add_entry(dof, node.dofs[c], -d[c] / d[p]);
        }
    }

    // The tangent plane's two directions and the normal, as an elastic support holds them (for the
    // count of free motions only: an elastic support adds stiffness, no constraint).
    std::vector<Tensor<1, 3>> elastic_directions(const SupportRestraint &r, const Tensor<1, 3> &normal)
    {
      std::vector<Tensor<1, 3>> directions;
      if (r.normal_stiffness > 0.)
        directions.push_back(normal);
      if (r.tangential_stiffness > 0.)
        {
          Tensor<1, 3> t = cross_product_3d(normal, std::abs(normal[0]) < 0.9 ? Tensor<1, 3>({1., 0., 0.}) :
                                                                                 Tensor<1, 3>({0., 1., 0.}));
          t /= t.norm();
          directions.push_back(t);
          directions.push_back(cross_product_3d(normal, t));
        }
      return directions;
    }

    // A symmetry's normal: the caught faces' mean normal, which every face must share (1e-6 rad).
    Tensor<1, 3> symmetry_normal(const Support &support, const BoundaryView &boundary, const Resolver &resolver,
                                 const MPI_Comm comm)
    {
      const auto   faces = resolver.faces_of(support);
      Tensor<1, 3> sum;
      for (const unsigned int f : faces)
        sum += boundary.faces[f].area * boundary.faces[f].normal;
      for (unsigned int d = 0; d < 3; ++d)
        sum[d] = Utilities::MPI::sum(sum[d], comm);
      const Tensor<1, 3> normal = sum / sum.norm();
      double             worst  = 0.;
      for (const unsigned int f : faces)
        worst = std::max(worst, (boundary.faces[f].normal - normal).norm());
      worst = Utilities::MPI::max(worst, comm);
      AssertThrow(worst <= 1e-6,
                  ExcMessage("The selection of " + support.label() + " is not planar (its faces' normals differ from "
                             "their mean by up to " + std::to_string(std::asin(std::min(worst, 1.)) * 180. / M_PI) +
                             " degrees): a symmetry needs a plane; use 'roller' on a curved face."));
      return normal;
    }
  } // namespace

  std::vector<Tensor<1, 3>> held_directions(const SupportRestraint &r, const Point<3> &x, const Tensor<1, 3> &normal,
                                            const double length_unit, const double tolerance)
  {
    if (r.kind == SupportRestraint::Kind::elastic)
      return elastic_directions(r, normal);
    return restrained_directions(r, x, normal, length_unit, tolerance);
  }

  ResolvedSupports resolve_supports(const std::vector<Support> &supports, const std::string &group_file,
                                    const std::map<std::string, int> &surfaces, const double length_unit,
                                    const Mapping<3> &mapping, const DoFHandler<3> &dof_handler,
                                    AffineConstraints<double> &constraints, const MPI_Comm comm)
  {
    BoundaryView       boundary(mapping, dof_handler);
    const Resolver     resolver(boundary, group_file, surfaces, length_unit, dof_handler.get_fe().degree, comm);
    ResolvedSupports   resolved;
    resolved.part_diagonal = resolver.diagonal;
    const IndexSet    &owned_dofs = dof_handler.locally_owned_dofs();
    const auto         owned      = [&](const Node &node) { return owned_dofs.is_element(node.dofs[0]); };
    std::vector<std::vector<Tensor<1, 3>>> rigid(boundary.nodes.size()), elastic(boundary.nodes.size());

    for (const Support &support : supports)
      {
        const auto   &r = support.restraint;
        SupportReport report;
        std::map<unsigned int, Tensor<1, 3>> node_normals; // area-weighted sums over the caught faces
        if (support.selection.selects_faces())
          for (const unsigned int f : resolver.faces_of(support))
            {
              const BoundaryFace &face = boundary.faces[f];
              if (face.owned)
                ++report.n_faces, report.area += face.area;
              for (const unsigned int node : face.nodes)
                node_normals[node] += face.area * face.normal;
              if (r.kind == SupportRestraint::Kind::elastic && face.owned)
                resolved.elastic_faces.push_back({face.cell, face.face, r.normal_stiffness, r.tangential_stiffness});
            }
        else
          for (const unsigned int node : resolver.nodes_of(support))
            node_normals[node] = Tensor<1, 3>();
        for (const auto &[node, normal] : node_normals)
          report.n_nodes += owned(boundary.nodes[node]);
        report.n_faces = Utilities::MPI::sum(report.n_faces, comm);
        report.n_nodes = Utilities::MPI::sum(report.n_nodes, comm);
        report.area    = Utilities::MPI::sum(report.area, comm);
        if (report.n_nodes == 0)
          resolver.refuse_empty(support);

        Tensor<1, 3> plane_normal; // a symmetry's: the faces' mean normal, checked to be theirs
        if (r.kind == SupportRestraint::Kind::symmetry)
          plane_normal = symmetry_normal(support, boundary, resolver, comm);
        for (const auto &[node, normal_sum] : node_normals)
          {
            const Tensor<1, 3> normal = r.kind == SupportRestraint::Kind::symmetry ? plane_normal :
                                        normal_sum.norm() > 0.                      ? normal_sum / normal_sum.norm() :
                                                                                      normal_sum;
            for (const auto &d : restrained_directions(r, boundary.nodes[node].x, normal, length_unit, resolver.tolerance))
              rigid[node].push_back(d);
            if (r.kind == SupportRestraint::Kind::elastic)
              for (const auto &d : elastic_directions(r, normal))
                elastic[node].push_back(d);
          }
        resolved.reports.push_back(report);
      }

    for (unsigned int i = 0; i < boundary.nodes.size(); ++i)
      {
        const auto held = orthonormal_span(rigid[i]);
        add_node_constraints(boundary.nodes[i], held, constraints);
        if (!owned(boundary.nodes[i]))
          continue;
        resolved.n_restrained_nodes += !held.empty();
        for (const auto &d : held)
          resolved.held.emplace_back(boundary.nodes[i].x, d);
        for (const auto &d : elastic[i])
          resolved.held.emplace_back(boundary.nodes[i].x, d);
      }
    resolved.n_restrained_nodes = Utilities::MPI::sum(resolved.n_restrained_nodes, comm);
    return resolved;
  }

  std::string ResolvedSupports::summary(const std::vector<Support> &supports) const
  {
    std::ostringstream out;
    for (unsigned int s = 0; s < supports.size(); ++s)
      out << (s ? "; " : "") << supports[s].label() << ": " << reports[s].n_faces << " mesh faces, "
          << std::setprecision(4) << reports[s].area << " m^2, " << reports[s].n_nodes << " nodes";
    return out.str();
  }

  void condense_weights(const AffineConstraints<double> &constraints,
                        std::vector<std::pair<types::global_dof_index, double>> &weights)
  {
    std::vector<std::pair<types::global_dof_index, double>> condensed;
    for (const auto &[dof, w] : weights)
      if (!constraints.is_constrained(dof))
        condensed.emplace_back(dof, w);
      else if (const auto *entries = constraints.get_constraint_entries(dof))
        for (const auto &[on, factor] : *entries)
          condensed.emplace_back(on, w * factor);
    weights = std::move(condensed);
  }

  bool has_coupling_constraints(const AffineConstraints<double> &constraints)
  {
    for (const auto &line : constraints.get_lines())
      if (!line.entries.empty())
        return true;
    return false;
  }
} // namespace modal_haptics
