#include "modal_space.h"

#include "atomic_file.h"
#include "space_phases.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
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

    // The serial backend of the space phases (space_phases.h): deal.II sparse matrices, a CHOLMOD or
    // UMFPACK factorization of K - shift M, every DoF on this process.
    class SerialSpace : public space_phases::PhasedSpace<SerialSpace>
    {
    public:
      using PhasedSpace::PhasedSpace;

      // The backend of space_phases.h.
      using Field = Vector<double>;
      struct Block // columns of n DoFs, one after the other, solved together
      {
        std::vector<double> values;
        std::size_t         n;
      };
      const std::vector<Field> &kept_modes() const { return eigen.eigenvectors; }
      const Field &ghosted(const Field &u) const { return u; }
      const Field &ghosted_mode(const unsigned int i) const { return eigen.eigenvectors[i]; }
      Field zero_field() const { return Field(dof_handler.n_dofs()); }
      std::vector<space_parts::EvaluationPoint> evaluation_points(const std::vector<meshing::Point3> &points,
                                                                  double *max_outside) const;
      Field patch_load(unsigned int vertex, const std::array<double, 3> &factor) const;
      void relieve_load(Field &load) const { relieve_load(load.begin()); }
      void solve_static(Field &u) { solve_static(u.data(), 1); }
      Block new_block(const unsigned int n_columns) const
      {
        return {std::vector<double>(n_columns * std::size_t(dof_handler.n_dofs()), 0.), dof_handler.n_dofs()};
      }
      void add_patch_loads(Block &X, unsigned int first_column, unsigned int vertex) const;
      void solve_static(Block &X) { solve_static(X.values.data(), X.values.size() / X.n); }
      const double *block_column(const Block &X, const unsigned int column) const { return &X.values[column * X.n]; }
      void sum_over_processes(std::vector<double> &) const {}
      std::array<Vector<double>, 6> rigid_body_motions(const Point<3> &centre) const;
      void fill_modes_at_vertices();
      void write_vtu(DataOut<3> &data_out) const
      {
        write_file_atomically(task.vtu_file, [&](std::ostream &out) { data_out.write_vtu(out); });
      }

      DoFHandler<3>                    dof_handler;
      SparseMatrix<double>             stiffness_matrix, mass_matrix;
      space_phases::SurfaceOperators   surface;
      std::vector<Field>               validation_fields; // full - modal error fields for VTU
      using SpaceBase::mapping;

    private:
      void assemble() override
      {
        read_mesh();
        setup_system();
        assemble_system();
      }
      void after_assembly() override
      {
        if (scene.output.export_matrices)
          export_matrices();
      }
      void solve_eigenproblem() override;
      void finish() override { result.factorization = factorization->statistics(); }

      void read_mesh();
      void setup_system();
      void assemble_system();
      void select_modes();
      void identify_rigid_body_modes();
      void relieve_load(double *load) const;
      void remove_rigid_motion(double *field) const;
      void solve_static(double *columns, unsigned int n_rhs);
      void export_matrices() const;

      const space_parts::PointLocator &locator() const;

      Triangulation<3>          triangulation;
      AffineConstraints<double> constraints;
      SparsityPattern           sparsity_pattern;
      std::unique_ptr<Factorization> factorization; // of K - shift M
      double                    shift = 0.;          // [rad^2/s^2]
      EigenSolution             eigen;
      // A free-floating part: the rigid-body motions, M-orthonormal, and M times each.
      std::vector<Vector<double>> rigid_modes, mass_times_rigid;
      mutable std::unique_ptr<space_parts::PointLocator> point_locator; // built on first use
    };

    // The mesh comes from gmsh in geometry units; we compute in SI. Inverted or degenerate tets are a
    // user error (a hand-made or foreign .msh): refuse them before they turn into negative Jacobians.
    void SerialSpace::read_mesh()
    {
      space_parts::read_mesh(scene, task, triangulation, result);
    }

    // Homogeneous Dirichlet conditions on the named clamp groups. A group that is missing from the
    // mesh, or present but with no face, is a user error: silently clamping nothing would give a
    // free-floating part.
    void SerialSpace::setup_system()
    {
      dof_handler.reinit(triangulation);
      dof_handler.distribute_dofs(fe);
      result.n_dofs = dof_handler.n_dofs();

      constraints.clear();
      space_parts::add_clamp_constraints(scene, task, mapping, dof_handler, constraints);
      constraints.close();
      result.n_clamped_dofs = constraints.n_constraints();
      for (types::global_dof_index i = 0; i < dof_handler.n_dofs(); ++i)
        if (constraints.is_constrained(i))
          result.clamped_dofs.push_back(i);

      DynamicSparsityPattern dsp(dof_handler.n_dofs());
      DoFTools::make_sparsity_pattern(dof_handler, dsp, constraints, /*keep_constrained_dofs*/ false);
      sparsity_pattern.copy_from(dsp);
      stiffness_matrix.reinit(sparsity_pattern);
      mass_matrix.reinit(sparsity_pattern);
      log(std::to_string(result.n_cells) + " tets, " + std::to_string(result.n_vertices) + " vertices, " +
          std::to_string(result.n_dofs) + " DoFs (P" + std::to_string(scene.element_degree) + "), " +
          std::to_string(result.n_clamped_dofs) + " clamped");
    }

    // K from isotropic linear elasticity, M consistent; and the rigid-body mass properties from the
    // same quadrature.
    void SerialSpace::assemble_system()
    {
      const auto assembler = space_parts::assemble_elasticity(scene, mapping, fe, quadrature,
                                                              dof_handler.active_cell_iterators(), constraints,
                                                              stiffness_matrix, mass_matrix);

      // distribute_local_to_global leaves a nonzero diagonal on constrained rows of both K and M,
      // which would be spurious eigenvalues K_ii / M_ii. With M_ii = 0 they move to infinity, where
      // shift-invert never finds them.
      for (const auto i : result.clamped_dofs)
        mass_matrix.set(i, i, 0.);
      result.n_spurious_rows = result.clamped_dofs.size();
      assembler.set_mass_properties(result);
    }

    void SerialSpace::solve_eigenproblem()
    {
      shift = std::copysign(std::pow(two_pi * scene.modes.shift, 2), scene.modes.shift);
      log("factorizing K (" + std::string(scene.modes.eigen_operator == EigenOperator::cholmod ? "CHOLMOD" : "UMFPACK") + ")");
      factorization = scene.modes.eigen_operator == EigenOperator::cholmod ?
                        make_cholmod_factorization(stiffness_matrix, &mass_matrix, shift) :
                        make_umfpack_factorization(stiffness_matrix, &mass_matrix, shift);
      const auto &f = factorization->statistics();
      std::ostringstream line;
      line << "factor: " << f.factor_nonzeros << " nonzeros, analyze " << f.analyze_seconds << " s, factorize "
           << f.factorize_seconds << " s";
      log(line.str());

      try
        {
          eigen = scene.modes.block_krylov ?
                    solve_block_shift_invert(mass_matrix, *factorization, shift, scene.modes.maximum_count,
                                             scene.modes.block_size, scene.modes.tolerance, verbose) :
                    solve_shift_invert(stiffness_matrix, mass_matrix, *factorization, shift,
                                       scene.modes.maximum_count, scene.modes.tolerance, verbose);
        }
      catch (const ExceptionBase &e)
        {
          // A free part's rigid-body modes are the shifted inverse's largest eigenvalues, 1 / |shift|:
          // with a tiny shift they dwarf the elastic ones and the block solver stalls (ARPACK does not).
          if (!scene.free_floating())
            throw;
          std::ostringstream message;
          e.print_info(message);
          AssertThrow(false, ExcMessage(message.str() + " The part is free-floating: a shift of larger magnitude "
                                        "(about a tenth of the first elastic frequency) or 'Modes/Eigensolver = "
                                        "arpack' converges where a shift close to 0 does not."));
        }
      result.eigensolver_method = scene.modes.block_krylov ?
                                    "block Krylov (shift-invert, blocks of " + std::to_string(scene.modes.block_size) + ")" :
                                                             "ARPACK dsaupd mode 3 (shift-invert)";
      result.n_operator_applications = eigen.n_operator_applications;
      result.arpack_seconds          = eigen.arpack_seconds;
      result.mass_product_seconds      = eigen.mass_product_seconds;
      result.orthogonalization_seconds = eigen.orthogonalization_seconds;
      identify_rigid_body_modes();
      // Rigid-body modes (lambda = 0) have no relative residual: theirs is taken against the first
      // elastic eigenvalue.
      result.self_check = check_eigenpairs(stiffness_matrix, mass_matrix, eigen.eigenvalues, eigen.eigenvectors,
                                           eigen.eigenvalues[result.n_rigid_body_modes]);
      std::ostringstream check;
      check << eigen.eigenvalues.size() << " modes in " << eigen.n_operator_applications << " solves, "
            << eigen.arpack_seconds << " s; f1 = " << std::sqrt(std::max(eigen.eigenvalues.front(), 0.)) / two_pi
            << " Hz; max |Phi^T M Phi - I| = " << result.self_check.orthonormality_error
            << ", max ||K phi - lambda M phi|| / ||lambda M phi|| = " << result.self_check.max_relative_residual
            << "; spurious eigenvalues: none below infinity (" << result.n_spurious_rows
            << " constrained rows have M_ii = 0)";
      log(check.str());
      select_modes();
    }

    void SerialSpace::select_modes()
    {
      std::vector<Vector<double>> kept;
      for (const unsigned int i : space_parts::select_modes(scene, eigen.eigenvalues, result))
        kept.push_back(std::move(eigen.eigenvectors[i]));
      eigen.eigenvectors = std::move(kept);
      log("kept " + std::to_string(result.eigenvalues.size()) + " modes, dropped " +
          std::to_string(result.dropped_modes.size()));
    }

    // A free part's six lowest computed modes must span its rigid-body motions (more zero-energy modes
    // mean a mesh in pieces or a mechanism). They are then replaced by the exact motions (lambda = 0,
    // M-orthonormal) and the elastic modes are made exactly M-orthogonal to them, so that no rigid
    // drift hides in an elastic mode and the kernel's omega = 0 modes are pure rigid motion.
    void SerialSpace::identify_rigid_body_modes()
    {
      if (!scene.free_floating())
        return;
      const Point<3> centre(result.centre_of_mass[0], result.centre_of_mass[1], result.centre_of_mass[2]);
      rigid_modes.clear();
      mass_times_rigid.clear();
      for (auto &motion : rigid_body_motions(centre))
        {
          for (int pass = 0; pass < 2; ++pass) // Gram-Schmidt twice in the M inner product
            remove_rigid_motion(motion.begin());
          motion /= std::sqrt(mass_matrix.matrix_norm_square(motion));
          Vector<double> M_motion(motion.size());
          mass_matrix.vmult(M_motion, motion);
          rigid_modes.push_back(std::move(motion));
          mass_times_rigid.push_back(std::move(M_motion));
        }

      auto &lambda = eigen.eigenvalues;
      auto &phi    = eigen.eigenvectors;
      const unsigned int n_rigid = rigid_modes.size();
      double outside = 0., largest_rigid = 0.;
      std::ostringstream found;
      for (unsigned int i = 0; i < n_rigid; ++i)
        {
          Vector<double> elastic_part = phi[i];
          remove_rigid_motion(elastic_part.begin());
          outside += mass_matrix.matrix_norm_square(elastic_part);
          largest_rigid = std::max(largest_rigid, std::abs(lambda[i]));
          result.rigid_computed_frequencies_hz.push_back(std::copysign(std::sqrt(std::abs(lambda[i])), lambda[i]) / two_pi);
          found << ' ' << result.rigid_computed_frequencies_hz.back();
        }
      result.rigid_subspace_sine = std::sqrt(outside);
      const double first_elastic_hz = std::sqrt(std::max(lambda[n_rigid], 0.)) / two_pi;
      AssertThrow(result.rigid_subspace_sine < 1e-6 && largest_rigid < 1e-6 * lambda[n_rigid],
                  ExcMessage("Space '" + task.name + "' is free-floating, but its six lowest modes (" + found.str() +
                             " Hz; the seventh at " + std::to_string(first_elastic_hz) + " Hz) are not its rigid-body "
                             "motions (M-distance " + std::to_string(result.rigid_subspace_sine) + "). A mesh in "
                             "several pieces or a mechanism has more zero-energy modes: check the geometry, or clamp "
                             "the part ('Geometry/Clamp groups')."));
      for (unsigned int i = 0; i < phi.size(); ++i)
        if (i < n_rigid)
          phi[i] = rigid_modes[i], lambda[i] = 0.;
        else
          {
            remove_rigid_motion(phi[i].begin());
            phi[i] /= std::sqrt(mass_matrix.matrix_norm_square(phi[i]));
          }
      result.n_rigid_body_modes = n_rigid;
      std::ostringstream line;
      line << "free-floating: the six lowest modes are rigid-body motions (computed" << found.str()
           << " Hz, M-distance from the exact rigid span " << result.rigid_subspace_sine
           << "), replaced by the exact motions at 0 Hz; first elastic mode " << first_elastic_hz << " Hz";
      log(line.str());
    }

    // x -= sum_k to_k (from_k . x): the two projections below, which are each other's transposes.
    void subtract_components(double *x, const std::size_t n, const std::vector<Vector<double>> &from,
                             const std::vector<Vector<double>> &to)
    {
      for (unsigned int k = 0; k < from.size(); ++k)
        {
          const double share = std::inner_product(x, x + n, from[k].begin(), 0.);
          for (std::size_t j = 0; j < n; ++j)
            x[j] -= share * to[k][j];
        }
    }

    // Inertia relief: the load's resultant force and moment accelerate the free part (load M R R^T f),
    // what remains, f - M R R^T f, is in equilibrium and deforms it.
    void SerialSpace::relieve_load(double *load) const
    {
      subtract_components(load, dof_handler.n_dofs(), rigid_modes, mass_times_rigid);
    }

    // The field's component M-orthogonal to the rigid-body motions found so far.
    void SerialSpace::remove_rigid_motion(double *field) const
    {
      subtract_components(field, dof_handler.n_dofs(), mass_times_rigid, rigid_modes);
    }

    // K u = f in place for n_rhs columns, with the factorization of A = K - shift M. Without a shift
    // that is one solve. With one, the solve is refined, u += A^-1 (f - K u), which shrinks each
    // elastic mode's error by |shift| / |lambda - shift| per step. A free part's loads are relieved
    // first and its solutions kept M-orthogonal to the rigid-body motions: the inertia-relief answer.
    void SerialSpace::solve_static(double *columns, const unsigned int n_rhs)
    {
      const std::size_t n = dof_handler.n_dofs();
      for (unsigned int b = 0; b < n_rhs; ++b)
        relieve_load(columns + b * n);
      if (shift == 0.)
        {
          factorization->solve_block(columns, n_rhs);
          return;
        }
      const std::vector<double> load(columns, columns + n * n_rhs);
      std::vector<double>       correction(load);
      std::fill(columns, columns + n * n_rhs, 0.);
      Vector<double> u(n), K_u(n);
      double         previous = std::numeric_limits<double>::infinity();
      for (unsigned int step = 1;; ++step)
        {
          factorization->solve_block(correction.data(), n_rhs);
          double worst = 0.;
          for (unsigned int b = 0; b < n_rhs; ++b)
            {
              double *x = columns + b * n, *residual = &correction[b * n];
              const double *f = &load[b * n];
              for (std::size_t j = 0; j < n; ++j)
                x[j] += residual[j];
              remove_rigid_motion(x);
              std::copy(x, x + n, u.begin());
              stiffness_matrix.vmult(K_u, u);
              double residual_norm = 0., load_norm = 0.;
              for (std::size_t j = 0; j < n; ++j)
                {
                  residual[j] = f[j] - K_u[j];
                  residual_norm += residual[j] * residual[j];
                  load_norm += f[j] * f[j];
                }
              worst = std::max(worst, load_norm > 0. ? std::sqrt(residual_norm / load_norm) : 0.);
            }
          result.static_solve_iterations = std::max(result.static_solve_iterations, step);
          if (worst <= 1e-12)
            return;
          // No longer shrinking: the rounding floor (a direct solve of K itself reaches about 1e-9
          // on a slender part), or no convergence at all.
          const bool stalled = worst >= 0.5 * previous;
          AssertThrow((!stalled || worst <= 1e-6) && step < 200,
                      ExcMessage("Space '" + task.name + "': the static solves do not converge with 'Modes/Shift' = " +
                                 std::to_string(scene.modes.shift) + " Hz (relative residual " + [&] { std::ostringstream r; r << worst; return r.str(); }() +
                                 " after " + std::to_string(step) + " refinements): choose a shift of smaller magnitude, "
                                 "well below the first elastic frequency."));
          if (stalled)
            return;
          previous = worst;
        }
    }

    const space_parts::PointLocator &SerialSpace::locator() const
    {
      if (!point_locator)
        point_locator = std::make_unique<space_parts::PointLocator>(triangulation, mapping);
      return *point_locator;
    }

    // Every cell is this process's: each point is located in the whole mesh.
    std::vector<space_parts::EvaluationPoint>
    SerialSpace::evaluation_points(const std::vector<meshing::Point3> &points, double *max_outside) const
    {
      std::vector<space_parts::EvaluationPoint> evaluated;
      for (const auto &x : points)
        {
          const auto located = locator().locate(x);
          if (max_outside)
            *max_outside = std::max(*max_outside, located.distance_outside);
          evaluated.push_back({DoFHandler<3>::active_cell_iterator(&triangulation, located.cell->level(),
                                                                   located.cell->index(), &dof_handler),
                               located.unit});
        }
      return evaluated;
    }

    SerialSpace::Field SerialSpace::patch_load(const unsigned int vertex, const std::array<double, 3> &factor) const
    {
      Field load = zero_field();
      surface.add_patch_load(vertex, factor, load);
      return load;
    }

    void SerialSpace::add_patch_loads(Block &X, const unsigned int first_column, const unsigned int vertex) const
    {
      const auto &W = surface.patch_loads.at(vertex);
      for (unsigned int c = 0; c < 3; ++c)
        for (const auto &[dof, w] : W[c])
          X.values[(first_column + c) * X.n + dof] += w;
    }

    // Modes at the mesh vertices for the HDF5 file (P2 vertex DoFs are the vertex values).
    void SerialSpace::fill_modes_at_vertices()
    {
      const unsigned int r = eigen.eigenvectors.size();
      result.modes_at_vertices.assign(std::size_t(r) * result.n_vertices * 3, 0.);
      for (const auto &cell : dof_handler.active_cell_iterators())
        for (unsigned int vtx = 0; vtx < 4; ++vtx)
          for (unsigned int c = 0; c < 3; ++c)
            {
              const auto dof = cell->vertex_dof_index(vtx, c);
              for (unsigned int i = 0; i < r; ++i)
                result.modes_at_vertices[(std::size_t(i) * result.n_vertices + cell->vertex_index(vtx)) * 3 + c] =
                  eigen.eigenvectors[i][dof];
            }
    }

    // Translations along x, y, z, then rotations about the axes through 'centre', as DoF fields: the
    // FE space holds them exactly (they are linear). Clamped DoFs keep their motion: M's clamped rows
    // are zero, so they add nothing to M-products.
    std::array<Vector<double>, 6> SerialSpace::rigid_body_motions(const Point<3> &centre) const
    {
      std::vector<Point<3>> support(dof_handler.n_dofs());
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      std::vector<unsigned int>            component(dof_handler.n_dofs());
      std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
      for (const auto &cell : dof_handler.active_cell_iterators())
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            component[dofs[i]] = fe.system_to_component_index(i).first;
        }
      std::array<Vector<double>, 6> motions;
      for (unsigned int k = 0; k < 6; ++k)
        {
          motions[k].reinit(dof_handler.n_dofs());
          for (types::global_dof_index i = 0; i < dof_handler.n_dofs(); ++i)
            motions[k][i] = space_parts::rigid_body_motion(k, support[i] - centre)[component[i]];
        }
      return motions;
    }


    // K and M for the benchmark's peers (scipy, SLEPc) in a plain binary CSR: int64 n, int64 nnz,
    // int64 row_start[n + 1], int32 column[nnz], float64 value[nnz], little-endian, full symmetric
    // storage, constrained rows as the eigensolve sees them.
    void SerialSpace::export_matrices() const
    {
      for (const auto &[matrix, suffix] : {std::make_pair(&stiffness_matrix, "K"), std::make_pair(&mass_matrix, "M")})
        write_file_atomically(scene.output_directory + "/" + task.name + "_" + suffix + ".csr",
                              [&](std::ostream &out) {
                                const std::int64_t n = matrix->m(), nnz = matrix->n_nonzero_elements();
                                std::vector<std::int64_t> row_start{0};
                                std::vector<std::int32_t> columns;
                                std::vector<double>       values;
                                for (std::int64_t row = 0; row < n; ++row)
                                  {
                                    for (auto it = matrix->begin(row); it != matrix->end(row); ++it)
                                      columns.push_back(it->column()), values.push_back(it->value());
                                    row_start.push_back(columns.size());
                                  }
                                Assert(std::int64_t(columns.size()) == nnz, ExcInternalError());
                                const auto write = [&](const auto &v) {
                                  out.write(reinterpret_cast<const char *>(v.data()), v.size() * sizeof(v[0]));
                                };
                                write(std::vector<std::int64_t>{n, nnz});
                                write(row_start);
                                write(columns);
                                write(values);
                              },
                              std::ios::binary);
      log("exported K and M to " + scene.output_directory + "/" + task.name + "_{K,M}.csr");
    }

  } // namespace

  ModalSpaceResult compute_modal_space(const SceneParameters &scene,
                                       const DisplaySurface  &display,
                                       const SpaceTask       &task,
                                       TimerOutput           &timer,
                                       const bool             verbose)
  {
    SerialSpace space(scene, display, task, timer, verbose);
    return space.run();
  }
  namespace space_parts
  {
    SpaceBase::SpaceBase(const SceneParameters &scene, const DisplaySurface &display, const SpaceTask &task,
                         TimerOutput &timer, const bool verbose)
      : scene(scene)
      , display(display)
      , task(task)
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

    void SpaceBase::log(const std::string &message) const
    {
      if (verbose)
        std::cout << "[" << task.name << "] " << message << std::endl;
    }

    ModalSpaceResult SpaceBase::run()
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
      phase("interpolation", [&] { interpolate(); });
      phase("static_correction", [&] { compute_static_correction(); });
      phase("validation", [&] { validate(); });
      phase("vtu_output", [&] { output_results(); });
      finish();
      return std::move(result);
    }

    Tensor<1, 3> rigid_body_motion(const unsigned int k, const Tensor<1, 3> &x)
    {
      Tensor<1, 3> u;
      if (k < 3)
        u[k] = 1.;
      else
        {
          Tensor<1, 3> axis;
          axis[k - 3] = 1.;
          u           = cross_product_3d(axis, x);
        }
      return u;
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

    // A group that is missing from the mesh, or present but with no face, is a user error: silently
    // clamping nothing would give a free-floating part. No group at all is a free-floating part.
    void add_clamp_constraints(const SceneParameters &scene, const SpaceTask &task, const Mapping<3> &mapping,
                               const DoFHandler<3> &dof_handler, AffineConstraints<double> &constraints,
                               const MPI_Comm comm)
    {
      std::vector<types::boundary_id> owned_ids;
      for (const auto &cell : dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
          for (const auto face : cell->face_indices())
            if (cell->face(face)->at_boundary())
              owned_ids.push_back(cell->face(face)->boundary_id());
      std::sort(owned_ids.begin(), owned_ids.end());
      owned_ids.erase(std::unique(owned_ids.begin(), owned_ids.end()), owned_ids.end());
      const auto                         all_ids = Utilities::MPI::compute_set_union(owned_ids, comm);
      const std::set<types::boundary_id> present_ids(all_ids.begin(), all_ids.end());
      for (const std::string &group : scene.clamp_groups)
        {
          const auto it = task.physical_surfaces.find(group);
          std::string known;
          for (const auto &[name, tag] : task.physical_surfaces)
            known += " '" + name + "'";
          AssertThrow(it != task.physical_surfaces.end(),
                      ExcMessage("Clamp group '" + group + "' (parameter 'Geometry/Clamp groups') is not a physical "
                                 "surface of mesh '" + task.msh_file + "'; it has:" + known + "."));
          AssertThrow(present_ids.count(it->second) == 1,
                      ExcMessage("Clamp group '" + group + "' of mesh '" + task.msh_file + "' has no boundary face."));
          VectorTools::interpolate_boundary_values(mapping, dof_handler, it->second,
                                                   Functions::ZeroFunction<3>(3), constraints);
        }
    }

    CellAssembler::CellAssembler(const MaterialParameters &material, const unsigned int dofs_per_cell)
      : material(material)
      , mu(material.youngs_modulus / (2. * (1. + material.poissons_ratio)))
      , lambda(material.youngs_modulus * material.poissons_ratio /
               ((1. + material.poissons_ratio) * (1. - 2. * material.poissons_ratio)))
      , strain(dofs_per_cell)
      , divergence(dofs_per_cell)
      , value(dofs_per_cell)
    {}

    void CellAssembler::assemble(const FEValues<3> &fe_values, FullMatrix<double> &cell_K, FullMatrix<double> &cell_M)
    {
      const FEValuesExtractors::Vector displacement(0);
      const unsigned int               dofs_per_cell = strain.size();
      cell_K = 0.;
      cell_M = 0.;
      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double JxW = fe_values.JxW(q);
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            {
              strain[i]     = fe_values[displacement].symmetric_gradient(i, q);
              divergence[i] = fe_values[displacement].divergence(i, q);
              value[i]      = fe_values[displacement].value(i, q);
            }
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            for (unsigned int j = 0; j <= i; ++j)
              {
                cell_K(i, j) += (lambda * divergence[i] * divergence[j] + 2. * mu * (strain[i] * strain[j])) * JxW;
                cell_M(i, j) += material.density * (value[i] * value[j]) * JxW;
              }
          const Point<3> &x = fe_values.quadrature_point(q);
          mass += material.density * JxW;
          first_moment += material.density * JxW * x;
          second_moment += material.density * JxW * outer_product(x, x);
        }
      for (unsigned int i = 0; i < dofs_per_cell; ++i)
        for (unsigned int j = i + 1; j < dofs_per_cell; ++j)
          {
            cell_K(i, j) = cell_K(j, i);
            cell_M(i, j) = cell_M(j, i);
          }
    }

    void CellAssembler::set_mass_properties(ModalSpaceResult &result, const std::function<double(double)> &reduce) const
    {
      Tensor<1, 3> first;
      Tensor<2, 3> second;
      for (unsigned int a = 0; a < 3; ++a)
        {
          first[a] = reduce(first_moment[a]);
          for (unsigned int b = 0; b < 3; ++b)
            second[a][b] = reduce(second_moment[a][b]);
        }
      result.mass = reduce(mass);
      const Tensor<1, 3> c = first / result.mass;
      for (unsigned int d = 0; d < 3; ++d)
        result.centre_of_mass[d] = c[d];
      // I = integral rho (|x - c|^2 1 - (x - c)(x - c)^T) = (tr S - ...) with S the second moment about c.
      const Tensor<2, 3> S = second - result.mass * outer_product(c, c);
      for (unsigned int a = 0; a < 3; ++a)
        for (unsigned int b = 0; b < 3; ++b)
          result.inertia[3 * a + b] = (a == b ? trace(S) : 0.) - S[a][b];
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
          d2 += std::pow(std::max({box.lower_bound(d) - p[d], 0., p[d] - box.upper_bound(d)}), 2);
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

    std::vector<std::pair<BoundingBox<3>, Triangulation<3>::active_cell_iterator>>
    PointLocator::candidate_boxes(const meshing::Point3 &x) const
    {
      // Every box that holds the point, then the nearest: a point of a fine mesh lies in the boxes of
      // more tets than the nearest few, and its own tet must be among those tried.
      std::vector<std::pair<BoundingBox<3>, Triangulation<3>::active_cell_iterator>> near;
      cache.get_locally_owned_cell_bounding_boxes_rtree().query(
        boost::geometry::index::intersects(Point<3>(x[0], x[1], x[2])), std::back_inserter(near));
      for (const auto &box_cell : nearest_boxes(x))
        if (std::none_of(near.begin(), near.end(), [&](const auto &other) { return other.second == box_cell.second; }))
          near.push_back(box_cell);
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

    LocatedPoint PointLocator::locate(const meshing::Point3 &x, const double within) const
    {
      const Point<3> p(x[0], x[1], x[2]);
      auto           near = candidate_boxes(x);
      near.erase(std::remove_if(near.begin(), near.end(),
                                [&](const auto &box_cell) { return squared_distance(box_cell.first, p) > within; }),
                 near.end());
      if (near.empty())
        return {Triangulation<3>::active_cell_iterator(), Point<3>(), std::numeric_limits<double>::infinity()};
      double                                 best_min = -1e300;
      Triangulation<3>::active_cell_iterator best_cell;
      std::array<double, 4>                  best_bary{};
      for (const auto &[box, cell] : near)
        {
          Tensor<2, 3> J;
          for (unsigned int d = 0; d < 3; ++d)
            for (unsigned int e = 0; e < 3; ++e)
              J[d][e] = cell->vertex(e + 1)[d] - cell->vertex(0)[d];
          const Tensor<1, 3>          xi   = invert(J) * (p - cell->vertex(0));
          const std::array<double, 4> bary = {1. - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]};
          const double                m    = *std::min_element(bary.begin(), bary.end());
          if (m > best_min)
            best_min = m, best_cell = cell, best_bary = bary;
        }
      double sum = 0.;
      for (double &b : best_bary)
        sum += (b = std::max(b, 0.));
      for (double &b : best_bary)
        b /= sum;
      return {best_cell, Point<3>(best_bary[1], best_bary[2], best_bary[3]), -best_min};
    }

    void add_shape_values(const DoFHandler<3>::active_cell_iterator &cell, const Point<3> &unit,
                          const unsigned int component, const double factor, DofWeights &out)
    {
      const auto                          &fe = cell->get_fe();
      std::vector<types::global_dof_index> dof_indices(fe.n_dofs_per_cell());
      cell->get_dof_indices(dof_indices);
      for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
        if (fe.system_to_component_index(i).first == component)
          {
            const double w = fe.shape_value(i, unit);
            if (w != 0.)
              out.emplace_back(dof_indices[i], factor * w);
          }
    }

    // The patch traction integrated with patch_quadrature against the FE basis: summed per DoF.
    PatchLoad make_patch_load(const DisplaySurface &display, const unsigned int vertex, const PointEvaluator &evaluate)
    {
      std::array<std::map<types::global_dof_index, double>, 3> columns;
      DofWeights                                               values;
      const auto                                               quadrature = patch_quadrature(display, vertex);
      std::vector<meshing::Point3>                             points;
      for (const auto &point : quadrature)
        points.push_back(point.x);
      const auto evaluated = evaluate(points);
      for (std::size_t k = 0; k < quadrature.size(); ++k)
        {
          const auto &[cell, unit] = evaluated[k];
          if (cell.state() != IteratorState::valid)
            continue;
          for (unsigned int c = 0; c < 3; ++c)
            {
              values.clear();
              add_shape_values(cell, unit, c, quadrature[k].weight, values);
              for (const auto &[dof, w] : values)
                columns[c][dof] += w;
            }
        }
      PatchLoad load;
      for (unsigned int c = 0; c < 3; ++c)
        load[c].assign(columns[c].begin(), columns[c].end());
      return load;
    }

    std::array<double, 3> modal_patch_response(const ModalSpaceResult &result, const unsigned int candidate,
                                               const unsigned int direction)
    {
      const unsigned int r = result.eigenvalues.size();
      const double      *B = &result.candidate_modes[std::size_t(candidate) * 3 * r];
      std::array<double, 3> u{};
      for (unsigned int i = 0; i < r; ++i)
        {
          const double q = B[direction * r + i] * static_gain(result.eigenvalues[i]);
          for (unsigned int c = 0; c < 3; ++c)
            u[c] += B[c * r + i] * q;
        }
      return u;
    }

    // The shared vertices (compared across spaces) are solved with the candidates.
    std::vector<unsigned int> plan_static_correction(const SceneParameters &scene, const SpaceTask &task,
                                                     ModalSpaceResult &result)
    {
      result.candidates     = task.candidates;
      const unsigned int nc = result.candidates.size();
      std::vector<unsigned int> loads = result.candidates;
      for (const unsigned int v : task.shared_vertices)
        if (!std::binary_search(result.candidates.begin(), result.candidates.end(), v))
          loads.push_back(v);
      result.candidate_modes.assign(3 * std::size_t(nc) * result.eigenvalues.size(), 0.);
      result.candidate_compliance.assign(9 * std::size_t(nc), 0.);
      if (scene.contact.cross_compliance && nc > 0)
        result.cross_compliance.assign(9 * std::size_t(nc) * nc, 0.);
      return loads;
    }

    void record_static_response(ModalSpaceResult &result, const SpaceTask &task, const unsigned int load,
                                const unsigned int load_vertex,
                                const std::function<std::array<double, 3>(unsigned int, unsigned int)> &averaged)
    {
      const unsigned int r = result.eigenvalues.size(), nc = result.candidates.size();
      // Full compliance at the load itself.
      std::array<double, 9> G{};
      for (unsigned int d = 0; d < 3; ++d)
        {
          const auto u = averaged(load_vertex, d);
          for (unsigned int c = 0; c < 3; ++c)
            G[3 * c + d] = u[c];
        }
      if (std::binary_search(task.shared_vertices.begin(), task.shared_vertices.end(), load_vertex))
        result.full_compliance[load_vertex] = G;
      if (load >= nc)
        return;
      for (unsigned int d = 0; d < 3; ++d)
        {
          const auto u_modal = modal_patch_response(result, load, d);
          for (unsigned int c = 0; c < 3; ++c)
            result.candidate_compliance[9 * std::size_t(load) + 3 * c + d] = G[3 * c + d] - u_modal[c];
        }
      if (result.cross_compliance.empty())
        return;
      const unsigned int stride = 3 * nc;
      const double      *Bb     = &result.candidate_modes[std::size_t(load) * 3 * r];
      for (unsigned int a = 0; a < nc; ++a)
        {
          const double *Ba = &result.candidate_modes[std::size_t(a) * 3 * r];
          for (unsigned int d = 0; d < 3; ++d)
            {
              const auto u = averaged(result.candidates[a], d);
              for (unsigned int c = 0; c < 3; ++c)
                {
                  double modal = 0.;
                  for (unsigned int i = 0; i < r; ++i)
                    modal += Ba[c * r + i] * Bb[d * r + i] * static_gain(result.eigenvalues[i]);
                  result.cross_compliance[std::size_t(3 * a + c) * stride + 3 * load + d] = u[c] - modal;
                }
            }
        }
    }

    std::string static_correction_summary(const ModalSpaceResult &result, const std::size_t n_loads)
    {
      const unsigned int nc = result.candidates.size();
      std::ostringstream line;
      line << "static correction: " << nc << " candidates (" << n_loads - nc << " shared vertices), "
           << result.correction_seconds_per_candidate * 1e3 << " ms per load";
      return line.str();
    }

    // Display field: modal vs full. The correction field d = full - modal is local; kept only where
    // |d| >= tolerance * max |d| (how it would be stored sparsely), the corrected field misses the
    // dropped part.
    // Area-weighted l2 error of the modal display field against full_field (3 per display vertex)
    // with the first k modes, k = 1..r, relative to full_field: how the drawn field converges with r.
    std::vector<double> display_error_by_mode_count(const ModalSpaceResult &result, const DisplaySurface &display,
                                                    const std::vector<double> &full_field,
                                                    const std::vector<double> &modal_coefficient)
    {
      const unsigned int  r = modal_coefficient.size();
      std::vector<double> remainder = full_field, errors;
      double              full_norm = 0.;
      for (std::size_t row = 0; row < full_field.size(); ++row)
        full_norm += display.vertex_area[row / 3] * full_field[row] * full_field[row];
      for (unsigned int k = 0; k < r; ++k)
        {
          double error = 0.;
          for (std::size_t row = 0; row < remainder.size(); ++row)
            {
              remainder[row] -= modal_coefficient[k] * result.display_modes[row * r + k];
              error += display.vertex_area[row / 3] * remainder[row] * remainder[row];
            }
          errors.push_back(std::sqrt(error / full_norm));
        }
      return errors;
    }

    void set_validation_errors(ValidationCase &vc, const ModalSpaceResult &result, const DisplaySurface &display,
                               const double correction_field_tolerance, const std::array<double, 3> &uc_full,
                               const std::array<double, 3> &uc_modal, const std::vector<double> &display_full,
                               const std::vector<double> &display_modal, const std::vector<double> &modal_coefficients)
    {
      const auto candidate_it = std::lower_bound(result.candidates.begin(), result.candidates.end(), vc.vertex);
      Assert(candidate_it != result.candidates.end() && *candidate_it == vc.vertex, ExcInternalError());
      const std::size_t candidate = candidate_it - result.candidates.begin();
      vc.full_response = uc_full;
      double full_norm = 0., modal_err = 0., corrected_err = 0.;
      for (unsigned int c = 0; c < 3; ++c)
        {
          const double corrected = uc_modal[c] + result.candidate_compliance[9 * candidate + 3 * c + vc.direction];
          full_norm += uc_full[c] * uc_full[c];
          modal_err += std::pow(uc_modal[c] - uc_full[c], 2);
          corrected_err += std::pow(corrected - uc_full[c], 2);
        }
      vc.contact_rel_error_modal     = std::sqrt(modal_err / full_norm);
      vc.contact_rel_error_corrected = std::sqrt(corrected_err / full_norm);

      const unsigned int  nv = display.n_vertices();
      std::vector<double> error2(nv, 0.), full2(nv, 0.);
      for (unsigned int v = 0; v < nv; ++v)
        for (unsigned int c = 0; c < 3; ++c)
          {
            const double full  = display_full[3 * v + c];
            const double modal = display_modal[3 * v + c];
            full2[v] += full * full;
            error2[v] += (modal - full) * (modal - full);
          }
      const double max_error = std::sqrt(*std::max_element(error2.begin(), error2.end()));
      const double max_full  = std::sqrt(*std::max_element(full2.begin(), full2.end()));
      const double keep      = correction_field_tolerance * max_error;
      double l2_full = 0., l2_err = 0., l2_corr = 0.;
      vc.correction_field_vertices = 0;
      for (unsigned int v = 0; v < nv; ++v)
        {
          l2_full += full2[v] * display.vertex_area[v];
          l2_err += error2[v] * display.vertex_area[v];
          if (std::sqrt(error2[v]) >= keep)
            ++vc.correction_field_vertices;
          else
            l2_corr += error2[v] * display.vertex_area[v];
        }
      vc.field_rel_error_modal     = std::sqrt(l2_err / l2_full);
      vc.field_max_error_modal     = max_error / max_full;
      vc.field_rel_error_corrected = std::sqrt(l2_corr / l2_full);
      vc.field_rel_error_by_modes  = display_error_by_mode_count(result, display, display_full, modal_coefficients);
    }

    // The kernel's formula: u_a = B_a Lambda^-1 (B_a^T F_a + B_b^T F_b) + C_aa F_a + C_ab F_b.
    double two_contact_error(const ModalSpaceResult &result, const std::array<unsigned int, 2> &vertices,
                             const std::array<std::array<double, 3>, 2> &full_responses)
    {
      const unsigned int r = result.eigenvalues.size(), nc = result.candidates.size();
      const auto        &forces = two_contact_forces;
      std::array<std::size_t, 2> index{};
      for (unsigned int h = 0; h < 2; ++h)
        index[h] = std::lower_bound(result.candidates.begin(), result.candidates.end(), vertices[h]) -
                   result.candidates.begin();
      std::vector<double> modal_force(r, 0.); // sum_h B_h^T F_h
      for (unsigned int h = 0; h < 2; ++h)
        for (unsigned int c = 0; c < 3; ++c)
          for (unsigned int i = 0; i < r; ++i)
            modal_force[i] += result.candidate_modes[(index[h] * 3 + c) * r + i] * forces[h][c];
      double worst = 0.;
      for (unsigned int h = 0; h < 2; ++h)
        {
          const auto &full  = full_responses[h];
          double      error = 0., norm = 0.;
          for (unsigned int c = 0; c < 3; ++c)
            {
              double predicted = 0.;
              for (unsigned int i = 0; i < r; ++i)
                predicted += result.candidate_modes[(index[h] * 3 + c) * r + i] * modal_force[i] * static_gain(result.eigenvalues[i]);
              for (unsigned int g = 0; g < 2; ++g)
                for (unsigned int d = 0; d < 3; ++d)
                  predicted += result.cross_compliance[(3 * index[h] + c) * 3 * nc + 3 * index[g] + d] * forces[g][d];
              error += std::pow(predicted - full[c], 2);
              norm += full[c] * full[c];
            }
          worst = std::max(worst, std::sqrt(error / norm));
        }
      return worst;
    }

    std::string validation_summary(const ModalSpaceResult &result)
    {
      double worst_modal = 0., worst_corrected = 0.;
      for (const auto &vc : result.validation)
        {
          worst_modal     = std::max(worst_modal, vc.contact_rel_error_modal);
          worst_corrected = std::max(worst_corrected, vc.contact_rel_error_corrected);
        }
      std::ostringstream line;
      line << "validation: " << result.validation.size() << " full static solves; contact error modal-only up to "
           << worst_modal << ", corrected up to " << worst_corrected;
      return line.str();
    }
  } // namespace space_parts

  namespace
  {
    // Adds sum_{i in [r_kept, r)} B[p][i] B[q][i] / lambda_i to the (rows x rows) block `target` for
    // the rows of B listed in `rows` (B: one row of r mode values per contact direction).
    void add_dropped_modes(const std::vector<double> &B, const unsigned int r, const unsigned int r_kept,
                           const std::vector<double> &eigenvalues, const std::vector<std::size_t> &rows, double *target)
    {
      for (std::size_t p = 0; p < rows.size(); ++p)
        for (std::size_t q = 0; q < rows.size(); ++q)
          for (unsigned int i = r_kept; i < r; ++i)
            target[p * rows.size() + q] += B[rows[p] * r + i] * B[rows[q] * r + i] * static_gain(eigenvalues[i]);
    }

    // Keeps the first r_kept of every block of r values.
    std::vector<double> keep_leading(const std::vector<double> &values, const unsigned int r, const unsigned int r_kept)
    {
      std::vector<double> kept;
      kept.reserve(values.size() / r * r_kept);
      for (std::size_t start = 0; start < values.size(); start += r)
        kept.insert(kept.end(), values.begin() + start, values.begin() + start + r_kept);
      return kept;
    }
  } // namespace

  ModalSpaceResult truncate_modal_space(const ModalSpaceResult &space, const unsigned int r_kept)
  {
    const unsigned int r = space.eigenvalues.size();
    AssertThrow(r_kept >= 1 && r_kept <= r,
                ExcMessage("Space '" + space.name + "' has " + std::to_string(r) + " modes; " + std::to_string(r_kept) +
                           " cannot be kept."));
    ModalSpaceResult kept = space;
    for (auto *list : {&kept.eigenvalues, &kept.frequencies_hz, &kept.damping_ratios})
      list->resize(r_kept);
    kept.participation.resize(std::size_t(r_kept) * 6);
    kept.modes_at_vertices.resize(std::size_t(r_kept) * space.n_vertex_rows() * 3);
    kept.display_modes   = keep_leading(space.display_modes, r, r_kept);
    kept.candidate_modes = keep_leading(space.candidate_modes, r, r_kept);

    const std::size_t nc = space.candidates.size();
    for (std::size_t a = 0; a < nc; ++a)
      add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, {3 * a, 3 * a + 1, 3 * a + 2},
                        &kept.candidate_compliance[9 * a]);
    if (!space.cross_compliance.empty())
      {
        std::vector<std::size_t> every_row(3 * nc);
        std::iota(every_row.begin(), every_row.end(), 0);
        add_dropped_modes(space.candidate_modes, r, r_kept, space.eigenvalues, every_row, kept.cross_compliance.data());
      }
    for (unsigned int i = r_kept; i < r; ++i)
      kept.dropped_modes.push_back({i, space.frequencies_hz[i], "truncated to " + std::to_string(r_kept) + " modes"});
    return kept;
  }
} // namespace modal_haptics
