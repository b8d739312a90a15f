// The phase after the eigensolve: the modes on the display surface (each display vertex located in
// the space's mesh), at the mesh vertices, the participation factors; and the patch loads W_v of
// display vertices, which the static correction, the validation and the validity phase load with.
#pragma once

#include "space/backend.h"

#include <sstream>

namespace modal_haptics
{
  namespace space_phases
  {
    // Each display vertex is located in the space's mesh (by the process whose cells hold it best)
    // and the FE basis is evaluated there; the modes at the display vertices and at the mesh
    // vertices follow.
    template <typename Backend>
    void interpolate_on_display_surface(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const ContactSurface &display     = in.display;
      double                max_outside = 0.;
      const auto            evaluated   = b.evaluation_points(display.vertices, &max_outside);
      for (unsigned int v = 0; v < display.n_vertices(); ++v)
        if (evaluated[v].cell.state() == dealii::IteratorState::valid)
          {
            const auto row = space_parts::shape_row(evaluated[v]);
            for (unsigned int c = 0; c < 3; ++c)
              {
                auto weights = row.component(c);
                b.condense(weights);
                b.surface.display_rows.emplace_back(3 * v + c, std::move(weights));
              }
          }

      const auto        &modes = b.kept_modes();
      const unsigned int r     = modes.size();
      const unsigned int nv    = display.n_vertices();
      std::vector<double> by_mode; // r blocks of 3 nv
      for (unsigned int i = 0; i < r; ++i)
        b.surface.append_local_display_values(b.ghosted_kept_modes()[i], nv, by_mode);
      b.sum_over_processes(by_mode);
      result.display_modes.resize(std::size_t(3) * nv * r);
      for (unsigned int row = 0; row < 3 * nv; ++row)
        for (unsigned int i = 0; i < r; ++i)
          result.display_modes[std::size_t(row) * r + i] = by_mode[std::size_t(i) * 3 * nv + row];
      b.fill_modes_at_vertices();
      std::ostringstream line;
      line << "display surface: " << nv << " vertices located, farthest outside the mesh by " << max_outside
           << " (barycentric)";
      in.log(line.str());
    }

    // Gamma = Phi^T M R with R the rigid translations and rotations about the centre of mass: how a
    // frame acceleration drives each mode.
    template <typename Backend>
    void compute_participation_factors(Backend &b, ModalSpaceResult &result)
    {
      const dealii::Point<3> c(result.centre_of_mass[0], result.centre_of_mass[1], result.centre_of_mass[2]);
      const auto            &modes = b.kept_modes();
      const unsigned int     r     = modes.size();
      result.participation.assign(std::size_t(r) * 6, 0.);
      auto       M_rigid = b.zero_field();
      const auto motions = b.rigid_body_motions(c);
      for (unsigned int k = 0; k < 6; ++k)
        {
          b.mass_matrix.vmult(M_rigid, motions[k]);
          for (unsigned int i = 0; i < r; ++i)
            result.participation[std::size_t(i) * 6 + k] = modes[i] * M_rigid;
        }
    }

    // Neighbouring patches share their triangles' quadrature points, bit for bit (a triangle is
    // split the same way in every patch that covers it): with every display vertex a load, a point
    // lies in a dozen patches. So the points of all the new patches are gathered, each is located
    // and its shape values evaluated once (space_parts::shape_row), in one call to the backend (the
    // same list on every process: the call is collective), and each patch reads its points' rows.
    template <typename Backend>
    void build_patch_loads(Backend &b, const PhaseInputs &in, const std::vector<unsigned int> &vertices)
    {
      std::vector<unsigned int> new_loads;
      for (const unsigned int v : vertices)
        if (!b.surface.patch_loads.count(v))
          new_loads.push_back(v);
      std::sort(new_loads.begin(), new_loads.end());
      new_loads.erase(std::unique(new_loads.begin(), new_loads.end()), new_loads.end());
      std::vector<std::vector<SurfacePoint>> quadratures;
      std::vector<meshing::Point3>           points;
      for (const unsigned int v : new_loads)
        {
          quadratures.push_back(patch_quadrature(in.display, v));
          for (const auto &point : quadratures.back())
            points.push_back(point.x);
        }
      std::sort(points.begin(), points.end());
      points.erase(std::unique(points.begin(), points.end()), points.end());
      const auto                           evaluated = b.evaluation_points(points, nullptr);
      std::vector<space_parts::ShapeRow>   rows(points.size());
      dealii::parallel::apply_to_subranges(
        std::size_t(0), points.size(),
        [&](const std::size_t first, const std::size_t last) {
          for (std::size_t k = first; k < last; ++k)
            rows[k] = space_parts::shape_row(evaluated[k]);
        },
        1024);
      // Each patch reads only the shared rows and the constraints: the patches split between threads.
      std::vector<space_parts::PatchLoad> loads(new_loads.size());
      dealii::parallel::apply_to_subranges(
        std::size_t(0), new_loads.size(),
        [&](const std::size_t first, const std::size_t last) {
          std::vector<const space_parts::ShapeRow *> rows_of_points;
          for (std::size_t n = first; n < last; ++n)
            {
              rows_of_points.clear();
              for (const auto &point : quadratures[n])
                rows_of_points.push_back(
                  &rows[std::lower_bound(points.begin(), points.end(), point.x) - points.begin()]);
              loads[n] = space_parts::make_patch_load(quadratures[n], rows_of_points);
              for (auto &direction : loads[n])
                b.condense(direction);
            }
        },
        64);
      for (std::size_t n = 0; n < new_loads.size(); ++n)
        b.surface.patch_loads[new_loads[n]] = std::move(loads[n]);
    }

  } // namespace space_phases
} // namespace modal_haptics
