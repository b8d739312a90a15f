// The validity analysis (large_deformation.h): the forces where a contact's felt compliance departs
// from the linear one, from the large-deformation solve's load ramp (LargeDeformationSolve,
// large_deformation_solve.h) at the validity contacts and from the modal series estimate over the
// display surface (the validity map).
#include "nonlinear/large_deformation_solve.h"

#include <mrt/surface_normals.h>

#include <deal.II/base/exceptions.h>
#include <deal.II/base/point.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    void set_validity_forces(ValidityCurve &curve)
    {
      const auto departure = [&](const std::size_t k) {
        const double compliance = curve.displacements[k] / curve.forces[k];
        return compliance > 0. ? std::abs(curve.linear_compliance / compliance - 1.) :
                                 std::numeric_limits<double>::infinity();
      };
      for (unsigned int level = 0; level < validity_departures.size(); ++level)
        {
          const double wanted = validity_departures[level];
          // Not reached on the curve: beyond the limit, or at most where the part stopped carrying.
          curve.validity_force[level] =
            curve.stop_reason.empty() ? std::numeric_limits<double>::infinity() : curve.force_reached;
          double previous_force = 0., previous_departure = 0.; // the curve starts linear at F = 0
          for (std::size_t k = 0; k < curve.forces.size(); ++k)
            {
              const double d = departure(k);
              if (d >= wanted)
                {
                  curve.validity_force[level] =
                    std::isfinite(d) ? previous_force + (curve.forces[k] - previous_force) * (wanted - previous_departure) /
                                                          (d - previous_departure) :
                                       previous_force;
                  break;
                }
              previous_force     = curve.forces[k];
              previous_departure = d;
            }
        }
    }

    std::array<double, 3> inward_normal(const ContactSurface &display, const unsigned int vertex,
                                        const std::function<double(const meshing::Point3 &)> &outside)
    {
      Tensor<1, 3> normal;
      const auto   point = [&](const unsigned int v) {
        return Point<3>(display.vertices[v][0], display.vertices[v][1], display.vertices[v][2]);
      };
      for (unsigned int k = display.vertex_triangle_offsets[vertex]; k < display.vertex_triangle_offsets[vertex + 1]; ++k)
        {
          const auto &t = display.triangles[display.vertex_triangles[k]];
          normal += cross_product_3d(point(t[1]) - point(t[0]), point(t[2]) - point(t[0])); // twice the area
        }
      AssertThrow(normal.norm() > 0., ExcMessage("Display vertex " + std::to_string(vertex) + " has no triangle."));
      normal /= normal.norm();
      // A tenth of the local triangle size away on either side: the side inside the part is the one
      // less far outside the mesh.
      const double step  = 0.1 * std::sqrt(3. * display.vertex_area[vertex]);
      const auto   moved = [&](const double sign) {
        const Point<3> x = point(vertex) + sign * step * normal;
        return outside({{x[0], x[1], x[2]}});
      };
      const double sign = moved(-1.) <= moved(1.) ? -1. : 1.;
      return {{sign * normal[0], sign * normal[1], sign * normal[2]}};
    }

    double modal_second_order(const ModalView &modal, const ModalSpaceResult &result, const unsigned int vertex,
                              const std::array<double, 3> &direction, std::vector<double> *q_out)
    {
      std::vector<double> q = modal.load(vertex, direction);
      for (unsigned int i = 0; i < q.size(); ++i)
        q[i] *= static_gain(result.eigenvalues[i]);
      const double c2 = -3. * modal.cubic.value(q);
      if (q_out)
        *q_out = std::move(q);
      return c2;
    }

    namespace
    {
      // The map's entries of a vertex: infinity (not reached) as validity_not_reached.
      void set_map_entry(ModalSpaceResult &result, const unsigned int vertex, const std::array<double, 3> &forces)
      {
        for (unsigned int k = 0; k < 3; ++k)
          result.validity_force[3 * std::size_t(vertex) + k] = std::isfinite(forces[k]) ? forces[k] : validity_not_reached;
      }

      // "1.2 / 5.9 / 11 N" for forces where infinity reads "not reached".
      std::string forces_text(const std::array<double, 3> &forces)
      {
        std::ostringstream out;
        out << std::setprecision(3);
        for (unsigned int k = 0; k < 3; ++k)
          {
            if (std::isfinite(forces[k]))
              out << forces[k];
            else
              out << "not reached";
            out << (k < 2 ? " / " : " N");
          }
        return out.str();
      }
    } // namespace

    void estimate_validity_map(const ContactSurface &display, const std::function<ModalView()> &make_modal,
                               ModalSpaceResult &result, const std::function<void(std::string)> &summarize)
    {
      const unsigned int nv = display.n_vertices();
      result.validity_force.assign(3 * std::size_t(nv), 0.);
      if (result.n_rigid_body_modes > 0)
        {
          result.validity_left_out = "the supports leave rigid motions free (" + result.free_motions +
                                     "), which a dead load would accelerate without bound";
          summarize("validity map left out: " + result.validity_left_out);
          return;
        }
      const ModalView     modal = make_modal();
      Timer               timer;
      std::vector<double> positions(3 * std::size_t(nv)), normals(3 * std::size_t(nv));
      std::vector<unsigned int> triangles;
      for (unsigned int v = 0; v < nv; ++v)
        std::copy(display.vertices[v].begin(), display.vertices[v].end(), &positions[3 * std::size_t(v)]);
      for (const auto &triangle : display.triangles)
        triangles.insert(triangles.end(), triangle.begin(), triangle.end());
      mrt::area_weighted_normals(positions.data(), nv, triangles.data(), display.triangles.size(), normals.data());
      unsigned int count = 0, lowest = 0;
      for (unsigned int v = 0; v < nv; ++v)
        if (result.felt_stiffness[v] > 0.)
          {
            const std::array<double, 3> inward = {{-normals[3 * v], -normals[3 * v + 1], -normals[3 * v + 2]}};
            const double                c1     = 1. / result.felt_stiffness[v];
            set_map_entry(result, v, series_validity_forces(c1, modal_second_order(modal, result, v, inward)));
            ++count;
            if (display.region[v] == result.index &&
                (display.region[lowest] != result.index || result.validity_force[3 * v] < result.validity_force[3 * lowest]))
              lowest = v;
          }
      result.validity_estimated_contacts  = count;
      result.validity_tensor_seconds      = modal.cubic.seconds;
      result.validity_seconds_per_contact = count ? timer.wall_time() / count : 0.;
      std::ostringstream line;
      line << "validity map: the second-order estimate at " << count << " contacts (" << result.eigenvalues.size()
           << "-mode cubic term in " << std::setprecision(3) << modal.cubic.seconds << " s, then "
           << 1e6 * result.validity_seconds_per_contact << " us per contact)";
      if (display.region[lowest] == result.index && result.validity_force[3 * lowest] > 0.)
        line << "; the lowest 1 % validity force of its region " << result.validity_force[3 * lowest]
             << " N at display vertex " << lowest << " (" << display.vertices[lowest][0] << ", "
             << display.vertices[lowest][1] << ", " << display.vertices[lowest][2] << ") m";
      summarize(line.str());
    }

    template <typename Algebra>
    void analyse_validity(const SpaceView<Algebra> &space, const SceneParameters &scene, const SpaceTask &task,
                          const ContactSurface &display,
                          const std::function<typename Algebra::Vector(unsigned int, const std::array<double, 3> &)> &patch_load,
                          const std::function<double(const meshing::Point3 &)> &outside,
                          const std::function<std::optional<ModalView>()> &make_modal, ModalSpaceResult &result, const std::function<void(std::string)> &log,
                          const std::function<void(std::string)> &summarize)
    {
      if (result.n_rigid_body_modes > 0)
        {
          summarize("validity analysis left out: the supports leave rigid motions free (" + result.free_motions +
              "), which a dead load would accelerate without bound");
          return;
        }
      const auto &contact = scene.contact;
      LoadRamp    ramp;
      ramp.force_limit = contact.force_limit;
      ramp.load_steps  = contact.validity_load_steps;
      const auto            law = validity_law(scene);
      LargeDeformationSolve<Algebra> solve(space, scene.material, scene.modes, law);
      const auto            modal = make_modal();
      for (const unsigned int vertex : task.validity_vertices)
        {
          const auto direction =
            contact.validity_direction ? *contact.validity_direction : inward_normal(display, vertex, outside);
          std::ostringstream heading;
          heading << "validity: display vertex " << vertex << ", pressed along (" << std::setprecision(3)
                  << direction[0] << ", " << direction[1] << ", " << direction[2] << ") up to " << ramp.force_limit
                  << " N ('Contact/Force limit'), " << law_name(law);
          log(heading.str());
          const auto before = solve.counts;
          auto curve      = solve.ramp_load(patch_load(vertex, direction), ramp, log);
          curve.vertex    = vertex;
          curve.direction = direction;
          std::ostringstream summary;
          summary << "validity: display vertex " << vertex << ": " << curve.forces.size() << " load levels in "
                  << std::fixed << std::setprecision(1) << curve.seconds << " s ("
                  << solve.counts.tangent_assemblies - before.tangent_assemblies << " tangent and "
                  << solve.counts.residual_assemblies - before.residual_assemblies << " residual assemblies, "
                  << solve.counts.factorizations - before.factorizations << " factorizations, "
                  << solve.counts.cg_iterations - before.cg_iterations << " CG iterations in "
                  << solve.counts.cg_solves - before.cg_solves << " solves; assemblies "
                  << solve.counts.assembly_seconds - before.assembly_seconds << " s, solves "
                  << solve.counts.solve_seconds - before.solve_seconds << " s); linear felt compliance holds to 1/5/10 % up to "
                  << std::defaultfloat << forces_text(curve.validity_force);
          if (!curve.stop_reason.empty())
            summary << "; the solve stopped at " << curve.force_reached << " N of " << ramp.force_limit
                    << " N: " << curve.stop_reason;
          summary << "; third-order estimate " << forces_text(curve.estimate_third_order.validity_force)
                  << ", second-order " << forces_text(curve.estimate_exact.validity_force) << " (exact, both "
                  << std::setprecision(2) << curve.estimate_seconds << " s)";
          if (modal)
            {
              std::vector<double> q;
              curve.estimate_modal.c2 = modal_second_order(*modal, result, vertex, direction, &q);
              curve.estimate_modal.validity_force =
                series_validity_forces(curve.linear_compliance, curve.estimate_modal.c2);
              // The tensor against Psi3 of the field it stands for (serial runs: the modes as serial vectors).
              if constexpr (std::is_same_v<Algebra, SerialAlgebra>)
                if (modal->serial_modes)
                  {
                    Vector<double> field(space.dof_handler.n_dofs());
                    for (unsigned int i = 0; i < q.size(); ++i)
                      field.add(q[i], (*modal->serial_modes)[i]);
                    const double direct = cubic_energy(space, scene.material, law, field);
                    curve.modal_cubic_check =
                      std::abs(modal->cubic.value(q) - direct) / std::max(std::abs(direct), 1e-300);
                  }
              summary << ", " << std::setprecision(3) << forces_text(curve.estimate_modal.validity_force) << " (modal)";
              // The map holds the full solve's forces where it pressed along the map's normal.
              if (!result.validity_force.empty() && !contact.validity_direction)
                set_map_entry(result, vertex, curve.validity_force);
            }
          summarize(summary.str());
          result.validity.push_back(std::move(curve));
        }
    }

    template void analyse_validity(const SpaceView<SerialAlgebra> &, const SceneParameters &, const SpaceTask &,
                                   const ContactSurface &,
                                   const std::function<Vector<double>(unsigned int, const std::array<double, 3> &)> &,
                                   const std::function<double(const meshing::Point3 &)> &,
                                   const std::function<std::optional<ModalView>()> &, ModalSpaceResult &,
                                   const std::function<void(std::string)> &, const std::function<void(std::string)> &);
    template void analyse_validity(const SpaceView<DistributedAlgebra> &, const SceneParameters &, const SpaceTask &,
                                   const ContactSurface &,
                                   const std::function<TrilinosWrappers::MPI::Vector(unsigned int, const std::array<double, 3> &)> &,
                                   const std::function<double(const meshing::Point3 &)> &,
                                   const std::function<std::optional<ModalView>()> &, ModalSpaceResult &,
                                   const std::function<void(std::string)> &, const std::function<void(std::string)> &);
  } // namespace nonlinear
} // namespace modal_haptics
