// The steps a space takes whatever its linear algebra (space_parts in modal_space.h): mesh, clamps,
// cell matrices, mode selection, point location, patch loads and the bookkeeping of the static
// correction and the validation.
#include "space/space_parts.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/grid_in.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/grid_tools_cache.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <boost/geometry/index/rtree.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    constexpr double two_pi = 2. * M_PI;
  } // namespace

  namespace space_parts
  {
    SpaceBase::SpaceBase(const SceneParameters &scene, const ContactSurface &display, const SpaceTask &task,
                         const std::string &vtu_file, TimerOutput &timer, const bool verbose)
      : scene(scene)
      , display(display)
      , task(task)
      , vtu_file(vtu_file)
      , timer(timer)
      , verbose(verbose)
      , fe(FE_SimplexP<3>(scene.element_degree), 3)
      , mapping(FE_SimplexP<3>(1))
      , quadrature(scene.element_degree + 1)
    {
      result.name   = task.name;
      result.index  = task.index;
      result.degree = scene.element_degree;
    }

    solver_choice::Settings solver_settings(const SceneParameters &scene)
    {
      const ModeParameters &m = scene.modes;
      return {m.eigensolver, m.factor_storage, m.factorization_kind, m.distributed_factorization};
    }

    void SpaceBase::log(const std::string &message) const
    {
      if (verbose)
        std::cout << "[" << task.name << "] " << message << std::endl;
    }

    namespace
    {
      bool space_summaries_printed = false;
    }

    void print_space_summaries(const bool on)
    {
      space_summaries_printed = on;
    }

    void SpaceBase::summarize(const std::string &message) const
    {
      if (space_summaries_printed && Utilities::MPI::this_mpi_process(MPI_COMM_WORLD) == 0)
        std::cout << "[" << task.name << "] " << message << std::endl;
      else
        log(message);
    }

    std::variant<ModalSpaceResult, solver_choice::Choice> SpaceBase::run()
    {
      const auto phase = [&](const std::string &name, const std::function<void()> &work) {
        TimerOutput::Scope scope(timer, name);
        Timer              wall;
        work();
        result.timings_s[name] += wall.wall_time();
      };
      phase("assembly", [&] { assemble(); });
      after_assembly();
      phase("eigensolve", [&] { solve_eigenproblem(); });
      if (choice.backend == solver_choice::Backend::mumps_on_this_process)
        return choice;
      result.eigensolver_method += choice.report_note;
      phase("interpolation", [&] { interpolate(); });
      phase("static_correction", [&] { compute_static_correction(); });
      phase("far_field", [&] { compute_far_field(); });
      phase("validation", [&] { validate(); });
      if (scene.contact.validity_estimate)
        phase("validity_estimate", [&] { estimate_validity(); });
      if (scene.contact.validity_analysis && !task.validity_vertices.empty())
        phase("validity", [&] { analyse_validity(); });
      phase("vtu_output", [&] { output_results(); });
      finish();
      return std::move(result);
    }

    std::string mode_field_name(const unsigned int i, const double frequency_hz)
    {
      std::ostringstream name;
      name << "mode_" << std::setw(2) << std::setfill('0') << i + 1 << "_" << std::fixed << std::setprecision(1)
           << frequency_hz << "Hz";
      return name.str();
    }

    std::string validation_field_name(const ValidationCase &vc)
    {
      return "validation_error_v" + std::to_string(vc.vertex) + "_" + "xyz"[vc.direction];
    }

    void read_mesh(const SceneParameters &scene, const SpaceTask &task, Triangulation<3> &mesh, ModalSpaceResult &result)
    {
      GridIn<3> grid_in;
      grid_in.attach_triangulation(mesh);
      std::ifstream input(task.msh_file);
      AssertThrow(input, ExcMessage("Cannot read mesh file '" + task.msh_file + "'."));
      grid_in.read_msh(input);
      GridTools::scale(scene.length_unit, mesh);

      const double length_scale = std::pow(GridTools::volume(mesh, MappingFE<3>(FE_SimplexP<3>(1))), 1. / 3.);
      for (const auto &cell : mesh.active_cell_iterators())
        {
          const Tensor<1, 3> a = cell->vertex(1) - cell->vertex(0), b = cell->vertex(2) - cell->vertex(0),
                             c = cell->vertex(3) - cell->vertex(0);
          const double signed_volume = (a * cross_product_3d(b, c)) / 6.;
          AssertThrow(signed_volume > 1e-14 * std::pow(length_scale, 3),
                      ExcMessage("Mesh '" + task.msh_file + "': tetrahedron " + std::to_string(cell->index()) +
                                 " at " + [&] { std::ostringstream s; s << cell->center(); return s.str(); }() +
                                 " is " + (signed_volume < 0 ? "inverted" : "degenerate") + " (signed volume " +
                                 std::to_string(signed_volume) + " m^3)."));
        }

      result.n_vertices = mesh.n_vertices();
      result.n_cells    = mesh.n_active_cells();
      for (const auto &v : mesh.get_vertices())
        for (unsigned int d = 0; d < 3; ++d)
          result.mesh_vertices.push_back(v[d]);
      for (const auto &cell : mesh.active_cell_iterators())
        for (unsigned int i = 0; i < 4; ++i)
          result.mesh_tets.push_back(cell->vertex_index(i));
    }

    ResolvedSupports apply_supports(const SceneParameters &scene, const SpaceTask &task, const Mapping<3> &mapping,
                                    const DoFHandler<3> &dof_handler, AffineConstraints<double> &constraints,
                                    const std::function<void(std::string)> &log, const MPI_Comm comm)
    {
      ResolvedSupports supports = resolve_supports(scene.supports, task.msh_file, task.physical_surfaces,
                                                   scene.length_unit, mapping, dof_handler, constraints, comm);
      if (!scene.supports.empty())
        log(supports.summary(scene.supports));
      const FreeMotions free = supports.free_motions(Point<3>(), comm);
      if (!free.motions.empty())
        log("the supports leave " + std::to_string(free.motions.size()) + " rigid-body motion" +
            (free.motions.size() > 1 ? "s" : "") + " free (" + free.describe() + ")");
      check_free_motions(scene, free, task.name);
      return supports;
    }

    void check_free_motions(const SceneParameters &scene, const FreeMotions &free, const std::string &space)
    {
      if (free.motions.empty())
        return;
      const std::string which = std::to_string(free.motions.size()) + " rigid-body motion" +
                                (free.motions.size() > 1 ? "s" : "") + " free (" + free.describe() + ")";
      const std::string the_supports = space.empty() ? "The supports" : "Space '" + space + "': the supports";
      AssertThrow(scene.modes.shift < 0.,
                  ExcMessage(the_supports + " ('Geometry/Supports') leave " + which +
                             ", so K is singular: set 'Modes/Shift' below zero (e.g. -0.1 times the first elastic "
                             "frequency), not " + std::to_string(scene.modes.shift) + " Hz, or hold the part."));
      AssertThrow(scene.modes.maximum_count > free.motions.size(),
                  ExcMessage(the_supports + " leave " + which + ", so 'Modes/Maximum number "
                             "of modes' = " + std::to_string(scene.modes.maximum_count) + " leaves no elastic mode."));
    }

    void set_mass_properties(const assembly::MassMoments &moments, ModalSpaceResult &result,
                             const std::function<double(double)> &reduce)
    {
      Tensor<1, 3> first_sum;
      Tensor<2, 3> second_sum;
      for (unsigned int a = 0; a < 3; ++a)
        {
          first_sum[a] = reduce(moments.first[a]);
          for (unsigned int b = 0; b < 3; ++b)
            second_sum[a][b] = reduce(moments.second[a][b]);
        }
      result.mass = reduce(moments.mass);
      const Tensor<1, 3> c = first_sum / result.mass;
      for (unsigned int d = 0; d < 3; ++d)
        result.centre_of_mass[d] = c[d];
      // I = integral rho (|x - c|^2 1 - (x - c)(x - c)^T) = (tr S - ...) with S the second moment about c.
      const Tensor<2, 3> S = second_sum - result.mass * outer_product(c, c);
      for (unsigned int a = 0; a < 3; ++a)
        for (unsigned int b = 0; b < 3; ++b)
          result.inertia[3 * a + b] = (a == b ? trace(S) : 0.) - S[a][b];
    }

    namespace
    {
      // A kept mode damped above this ratio barely oscillates (critical damping is 1): the hand feels
      // a slow creep, not the part's vibration (README, 'Damping/Model').
      constexpr double felt_damping_limit = 0.5;

      // "the 500 Hz cut-off ('Modes/Cut-off rule' = haptic: half 'Modes/Haptic rate')"
      std::string cut_off_text(const ModeParameters &modes, const double cut_off_hz)
      {
        const bool         haptic = modes.cut_off_rule == CutOffRule::haptic;
        std::ostringstream out;
        out << "the " << cut_off_hz << " Hz cut-off ('Modes/Cut-off rule' = " << (haptic ? "haptic" : "display")
            << ": half 'Modes/" << (haptic ? "Haptic" : "Display") << " rate')";
        return out.str();
      }

      // A warning on the first kept vibration mode whose damping ratio exceeds felt_damping_limit,
      // naming the damping parameters that set it.
      void warn_about_over_damping(const SceneParameters &scene, const ModalSpaceResult &result)
      {
        std::vector<unsigned int> over;
        for (unsigned int i = 0; i < result.frequencies_hz.size(); ++i)
          if (result.frequencies_hz[i] > 0. && result.damping_ratios[i] > felt_damping_limit)
            over.push_back(i);
        // Once per run: the damping parameters are the scene's, and every space keeps alike modes.
        static bool warned = false;
        if (over.empty() || warned || dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD) != 0)
          return;
        warned = true;
        const unsigned int  i     = over.front();
        const auto         &d     = scene.damping;
        const double        omega = two_pi * result.frequencies_hz[i];
        std::ostringstream out;
        out << std::setprecision(3) << "Warning: space '" << result.name << "': mode " << i + 1 << " ("
            << result.frequencies_hz[i] << " Hz) has a damping ratio of " << result.damping_ratios[i]
            << ", above " << felt_damping_limit << ": so damped a mode is not felt as a vibration";
        if (over.size() > 1)
          out << " (" << over.size() - 1 << " more kept mode" << (over.size() > 2 ? "s" : "") << " above it)";
        if (d.rayleigh)
          out << ". It comes from 'Damping/Rayleigh alpha' = " << d.alpha << " 1/s (alpha / (2 omega) = "
              << d.alpha / (2. * omega) << ") and 'Damping/Rayleigh beta' = " << d.beta << " s (beta omega / 2 = "
              << d.beta * omega / 2. << "): lower the larger, or set 'Damping/Model' = modal";
        else
          out << ". It is 'Damping/Modal damping ratio' = " << d.modal_ratio << ": lower it";
        std::cerr << out.str() << "." << std::endl;
      }

      // A first vibration frequency far outside what a hand can feel or a loop can follow says more
      // often that the lengths were read in the wrong unit (1000 times too small: 1000 times faster)
      // than that the part is so.
      void warn_about_first_frequency(const SceneParameters &scene, const ModalSpaceResult &result)
      {
        const auto &f     = result.computed_frequencies_hz;
        const auto  first = std::find_if(f.begin(), f.end(), [](const double x) { return x > 0.; });
        if (first == f.end() || (*first >= 0.1 && *first <= 1e5) ||
            dealii::Utilities::MPI::this_mpi_process(MPI_COMM_WORLD) != 0)
          return;
        std::cerr << std::setprecision(4) << "Warning: space '" << result.name << "': its first vibration frequency is "
                  << *first << " Hz, " << (*first > 1e5 ? "above 100 kHz" : "below 0.1 Hz")
                  << ": is 'Geometry/Length unit' = " << scene.length_unit
                  << " m right? Lengths read 1000 times too " << (*first > 1e5 ? "small" : "large")
                  << " make every frequency about 1000 times too " << (*first > 1e5 ? "high" : "low") << "."
                  << std::endl;
      }
    } // namespace

    std::string mode_selection_summary(const SceneParameters &scene, const ModalSpaceResult &result)
    {
      const auto        &modes    = scene.modes;
      const std::size_t  kept     = result.frequencies_hz.size(), dropped = result.dropped_modes.size();
      const std::size_t  computed = result.computed_frequencies_hz.size();
      std::ostringstream out;
      out << "kept " << kept << " mode" << (kept == 1 ? "" : "s") << ": ";
      if (modes.cut_off_rule == CutOffRule::none)
        return out.str() + "every computed one ('Modes/Cut-off rule' = none, 'Modes/Maximum number of modes' = " +
               std::to_string(computed) + ")";
      const std::size_t below = std::count_if(result.computed_frequencies_hz.begin(), result.computed_frequencies_hz.end(),
                                              [&](const double f) { return f <= result.cut_off_hz; });
      const std::string cut_off = cut_off_text(modes, result.cut_off_hz);
      if (below == computed)
        out << "all " << computed << " computed ('Modes/Maximum number of modes') lie below " << cut_off
            << "; more may lie below it";
      else if (kept == below)
        out << "those below " << cut_off;
      else
        out << below << " below " << cut_off << ", raised to the floor of " << modes.minimum_count
            << " ('Modes/Minimum number of modes')";
      // The eigensolve stops where the count is decided (CutOffStop): the block Krylov method drops at
      // most the one above the cut-off, ARPACK and LOBPCG what their last run found beyond it.
      if (dropped > 0)
        out << "; dropped " << dropped << " above it";
      return out.str();
    }

    double shift_eigenvalue(const ModeParameters &modes)
    {
      return std::copysign(std::pow(two_pi * modes.shift, 2), modes.shift);
    }

    CutOffStop cut_off_stop(const ModeParameters &modes)
    {
      return {modes.minimum_count, std::pow(two_pi * modes.cut_off_frequency(), 2)};
    }

    std::string sought_modes(const ModeParameters &modes)
    {
      const bool cut = modes.cut_off_rule != CutOffRule::none;
      return std::string(cut ? "up to " : "") + std::to_string(modes.maximum_count) + " modes" +
             (cut ? ", until the cut-off's count is decided" : "");
    }

    // The cut-off rule drops modes above its frequency, but never below the floor count; the report
    // says which modes went and why.
    std::vector<unsigned int> select_modes(const SceneParameters &scene, const std::vector<double> &eigenvalues,
                                           ModalSpaceResult &result)
    {
      result.computed_frequencies_hz.clear();
      for (const double lambda : eigenvalues)
        result.computed_frequencies_hz.push_back(std::sqrt(std::max(lambda, 0.)) / two_pi);
      result.cut_off_hz = scene.modes.cut_off_frequency();
      std::vector<unsigned int> kept;
      for (unsigned int i = 0; i < eigenvalues.size(); ++i)
        {
          const double f = result.computed_frequencies_hz[i];
          if (f > result.cut_off_hz && kept.size() >= scene.modes.minimum_count)
            {
              std::ostringstream reason;
              reason << "above the cut-off " << result.cut_off_hz << " Hz ("
                     << (scene.modes.cut_off_rule == CutOffRule::display ? "half the display rate" : "half the haptic rate")
                     << ")";
              result.dropped_modes.push_back({i, f, reason.str()});
              continue;
            }
          result.eigenvalues.push_back(eigenvalues[i]);
          result.frequencies_hz.push_back(f);
          result.damping_ratios.push_back(scene.damping.ratio(std::sqrt(std::max(eigenvalues[i], 0.))));
          kept.push_back(i);
        }
      // A space without modes cannot move: the user asked for something else.
      AssertThrow(!kept.empty(),
                  ExcMessage("Space '" + result.name + "': the cut-off " + std::to_string(result.cut_off_hz) +
                             " Hz ('Modes/Cut-off rule') lies below its first frequency " +
                             std::to_string(result.computed_frequencies_hz.front()) +
                             " Hz, so no mode would be kept. Choose another rule or rate, or set "
                             "'Modes/Minimum number of modes' to at least 1."));
      warn_about_over_damping(scene, result);
      warn_about_first_frequency(scene, result);
      return kept;
    }

    PointLocator::PointLocator(const Triangulation<3> &mesh, const Mapping<3> &mapping)
      : cache(mesh, mapping)
    {}

    namespace
    {
      double squared_distance(const BoundingBox<3> &box, const Point<3> &p)
      {
        double d2 = 0.;
        for (unsigned int d = 0; d < 3; ++d)
          {
            const double outside = std::max({box.lower_bound(d) - p[d], 0., p[d] - box.upper_bound(d)});
            d2 += outside * outside;
          }
        return d2;
      }
    } // namespace

    std::vector<std::pair<BoundingBox<3>, Triangulation<3>::active_cell_iterator>>
    PointLocator::nearest_boxes(const meshing::Point3 &x) const
    {
      std::vector<std::pair<BoundingBox<3>, Triangulation<3>::active_cell_iterator>> near;
      cache.get_locally_owned_cell_bounding_boxes_rtree().query(
        boost::geometry::index::nearest(Point<3>(x[0], x[1], x[2]), n_nearest), std::back_inserter(near));
      return near;
    }

    std::array<double, PointLocator::n_nearest> PointLocator::nearest_box_distances(const meshing::Point3 &x) const
    {
      std::array<double, n_nearest> distances;
      distances.fill(std::numeric_limits<double>::infinity());
      const auto near = nearest_boxes(x);
      for (std::size_t k = 0; k < near.size(); ++k)
        distances[k] = squared_distance(near[k].first, Point<3>(x[0], x[1], x[2]));
      std::sort(distances.begin(), distances.end());
      return distances;
    }

    namespace
    {
      // The point's barycentric coordinates in a tet (its vertices' affine map).
      std::array<double, 4> barycentric(const Triangulation<3>::active_cell_iterator &cell, const Point<3> &p)
      {
        Tensor<2, 3> J;
        for (unsigned int d = 0; d < 3; ++d)
          for (unsigned int e = 0; e < 3; ++e)
            J[d][e] = cell->vertex(e + 1)[d] - cell->vertex(0)[d];
        const Tensor<1, 3> xi = invert(J) * (p - cell->vertex(0));
        return {{1. - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]}};
      }
    } // namespace

    // The tet whose smallest barycentric coordinate is largest (the one holding the point, or the
    // nearest for a point just outside the mesh), among the cells whose boxes hold the point and,
    // unless one of those holds it, the n_nearest nearest boxes: a point of a fine mesh lies in the
    // boxes of more tets than the nearest few, and its own tet must be among those tried; the
    // nearest-box query costs more than the rest together, and most points are inside a tet.
    LocatedPoint PointLocator::locate(const meshing::Point3 &x, const double within) const
    {
      const Point<3> p(x[0], x[1], x[2]);
      double                                 best_min = -std::numeric_limits<double>::infinity();
      Triangulation<3>::active_cell_iterator best_cell;
      std::array<double, 4>                  best_bary{};
      std::vector<Triangulation<3>::active_cell_iterator> tried;
      const auto try_boxes = [&](const auto &boxes) {
        for (const auto &[box, cell] : boxes)
          if (squared_distance(box, p) <= within && std::find(tried.begin(), tried.end(), cell) == tried.end())
            {
              tried.push_back(cell);
              const auto   bary = barycentric(cell, p);
              const double m    = *std::min_element(bary.begin(), bary.end());
              if (m > best_min)
                best_min = m, best_cell = cell, best_bary = bary;
            }
      };
      std::vector<std::pair<BoundingBox<3>, Triangulation<3>::active_cell_iterator>> holding;
      cache.get_locally_owned_cell_bounding_boxes_rtree().query(boost::geometry::index::intersects(p),
                                                                 std::back_inserter(holding));
      try_boxes(holding);
      if (best_min < 0.)
        try_boxes(nearest_boxes(x));
      if (tried.empty())
        return {Triangulation<3>::active_cell_iterator(), Point<3>(), std::numeric_limits<double>::infinity()};
      double sum = 0.;
      for (double &b : best_bary)
        sum += (b = std::max(b, 0.));
      for (double &b : best_bary)
        b /= sum;
      return {best_cell, Point<3>(best_bary[1], best_bary[2], best_bary[3]), -best_min};
    }

    ShapeRow shape_row(const EvaluationPoint &point)
    {
      ShapeRow row;
      if (point.cell.state() != IteratorState::valid)
        return row;
      const auto &fe = point.cell->get_fe();
      AssertThrow(fe.n_base_elements() == 1 && fe.n_components() == 3,
                  ExcMessage("shape_row: one scalar element for the three components"));
      const auto        &scalar = fe.base_element(0);
      const unsigned int n      = scalar.n_dofs_per_cell();
      row.values.resize(n);
      for (unsigned int j = 0; j < n; ++j)
        row.values[j] = scalar.shape_value(j, point.unit);
      std::vector<types::global_dof_index> dof_indices(fe.n_dofs_per_cell());
      point.cell->get_dof_indices(dof_indices);
      row.dofs.resize(3 * n);
      for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
        {
          const auto [component, j]  = fe.system_to_component_index(i);
          row.dofs[component * n + j] = dof_indices[i];
        }
      row.cell = point.cell->active_cell_index();
      return row;
    }

    DofWeights ShapeRow::component(const unsigned int c) const
    {
      DofWeights weights;
      for (unsigned int j = 0; j < values.size(); ++j)
        if (values[j] != 0.)
          weights.emplace_back(dofs[c * values.size() + j], values[j]);
      return weights;
    }

    // The patch traction integrated with patch_quadrature against the FE basis: the points of one
    // cell summed per function first (a patch has ~100 points in a few dozen cells), then per DoF.
    PatchLoad make_patch_load(const std::vector<SurfacePoint> &quadrature, const std::vector<const ShapeRow *> &rows)
    {
      std::vector<std::size_t> order;
      for (std::size_t k = 0; k < quadrature.size(); ++k)
        if (!rows[k]->values.empty())
          order.push_back(k);
      std::stable_sort(order.begin(), order.end(),
                       [&](const std::size_t a, const std::size_t b) { return rows[a]->cell < rows[b]->cell; });
      PatchLoad           load;
      std::vector<double> sum;
      for (std::size_t first = 0; first < order.size();)
        {
          const ShapeRow &row  = *rows[order[first]];
          const auto      n    = row.values.size();
          std::size_t     last = first;
          sum.assign(n, 0.);
          for (; last < order.size() && rows[order[last]]->cell == row.cell; ++last)
            for (unsigned int j = 0; j < n; ++j)
              sum[j] += quadrature[order[last]].weight * rows[order[last]]->values[j];
          for (unsigned int c = 0; c < 3; ++c)
            for (unsigned int j = 0; j < n; ++j)
              if (sum[j] != 0.)
                load[c].emplace_back(row.dofs[c * n + j], sum[j]);
          first = last;
        }
      // A DoF on a face or edge is shared by cells: its terms summed in the order of the cells.
      for (auto &column : load)
        {
          std::stable_sort(column.begin(), column.end(), [](const auto &a, const auto &b) { return a.first < b.first; });
          std::size_t kept = 0;
          for (std::size_t i = 0; i < column.size(); ++i)
            if (kept > 0 && column[kept - 1].first == column[i].first)
              column[kept - 1].second += column[i].second;
            else
              column[kept++] = column[i];
          column.resize(kept);
        }
      return load;
    }

  } // namespace space_parts
} // namespace modal_haptics
