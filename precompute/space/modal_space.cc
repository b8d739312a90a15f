// The serial space: the serial backend of the space phases (space/phase_*.h) over deal.II sparse
// matrices and a CHOLMOD or UMFPACK factorization, its eigensolve (ARPACK or block Krylov, with
// the rigid-body modes of a free part) and the CSR export of K and M for the benchmarks.
#include "space/modal_space.h"

#include "solvers/amg_eigensolver.h"
#include "output/atomic_file.h"
#include "nonlinear/large_deformation.h"
#include "space/distributed_space.h"
#include "space/phased_space.h"

#include <deal.II/base/parallel.h>
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

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <future>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    constexpr double two_pi = 2. * M_PI;

    // The serial backend of the space phases (space/phase_*.h): deal.II sparse matrices, a CHOLMOD or
    // UMFPACK factorization of K - shift M, every DoF on this process.
    class SerialSpace : public space_phases::PhasedSpace<SerialSpace>
    {
    public:
      using PhasedSpace::PhasedSpace;

      // The backend of the phases (space/backend.h).
      using Field = Vector<double>;
      struct Block // columns of n DoFs, one after the other, solved together
      {
        std::vector<double> values;
        std::size_t         n;
      };
      const std::vector<Field> &kept_modes() const { return eigen.eigenvectors; }
      const std::vector<Field> &ghosted_kept_modes() const { return eigen.eigenvectors; }
      const Field &ghosted(const Field &u) const { return u; }
      Field zero_field() const { return Field(dof_handler.n_dofs()); }
      std::vector<space_parts::EvaluationPoint> evaluation_points(const std::vector<meshing::Point3> &points,
                                                                  double *max_outside) const;
      Field patch_load(unsigned int vertex, const std::array<double, 3> &factor) const;
      nonlinear::SpaceView<nonlinear::SerialAlgebra> validity_space();
      void relieve_load(Field &load) const { relieve_load(load.begin()); }
      void solve_static(std::vector<Field> &fields);
      Block new_block(const unsigned int n_columns) const
      {
        return {std::vector<double>(n_columns * std::size_t(dof_handler.n_dofs()), 0.), dof_handler.n_dofs()};
      }
      void add_patch_loads(Block &X, unsigned int first_column, unsigned int vertex) const;
      void add_combined_patch_loads(Block &X, const std::vector<const space_parts::DofWeights *> &rows,
                                    const double *weights, const unsigned int count) const
      {
        surface.add_rows_to_columns(rows, weights, count, X.values.data(), X.n);
      }
      void patch_row_averages(const Block &X, const std::vector<const space_parts::DofWeights *> &rows,
                              const unsigned int count, double *averages) const
      {
        surface.row_averages_of_columns(rows, X.values.data(), X.n, count, averages);
      }
      void solve_static(Block &X) { solve_static(X.values.data(), X.values.size() / X.n); }
      unsigned int columns_per_static_solve(const unsigned int wanted) const
      {
        return amg_inverse() ? amg_inverse()->columns_fitting_one_solve(wanted) : wanted;
      }
      bool group_grams(const std::vector<ContactGroup> &groups, std::vector<std::vector<double>> &grams);
      const double *block_column(const Block &X, const unsigned int column) const { return &X.values[column * X.n]; }
      void sum_over_processes(std::vector<double> &) const {}
      void condense(space_parts::DofWeights &weights) const { condense_weights(constraints, weights); }
      Field output_field(const Field &u) const
      {
        Field field = u;
        if (coupled_constraints)
          constraints.distribute(field);
        return field;
      }
      std::array<Vector<double>, 6> rigid_body_motions(const Point<3> &centre) const;
      void fill_modes_at_vertices();
      // On a thread of its own: the next space starts meanwhile (the pipeline waits for it before
      // the run's files are renamed into place).
      void write_vtu(space_phases::VtuOutput &data_out) const
      {
        BackgroundWrites::of_this_process().write_file_atomically(
          vtu_file, [patches = data_out.take_patches()](std::ostream &out) { patches->write(out); });
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
        start_fill_ordering();
        assemble_system();
      }
      void after_assembly() override
      {
        if (scene.output.export_matrices)
          export_matrices();
      }
      void solve_eigenproblem() override;
      void finish() override;

      void read_mesh();
      void setup_system();
      void assemble_system();
      // What the solver choice knows once the supports are set up (their free motions, where it
      // asks for them).
      solver_choice::Known known_with_supports() const;
      // Where the choice factorizes with CHOLMOD: its fill-reducing ordering, on a thread of its
      // own while K and M are assembled (METIS needs the sparsity pattern only, and the assembly
      // leaves part of a core idle). factorize_as_chosen takes it.
      void            start_fill_ordering();
      void            factorize_as_chosen();
      EigenSolution   solve_with_lobpcg_amg();
      void select_modes();
      void identify_rigid_body_modes();
      std::vector<Vector<double>> free_motion_fields(const FreeMotions &free) const;
      std::vector<unsigned int>   dof_components() const; // the displacement component of each DoF
      void relieve_load(double *load) const;
      void remove_rigid_motion(double *field) const;
      void solve_static(double *columns, unsigned int n_rhs);
      void export_matrices() const;

      const space_parts::PointLocator &locator() const;

      Triangulation<3>          triangulation;
      AffineConstraints<double> constraints;
      SparsityPattern           sparsity_pattern;
      std::unique_ptr<Factorization> factorization; // of K - shift M, or the AMG-preconditioned CG
      // The factorization on the path without one (null on the direct path).
      AmgShiftedInverse *amg_inverse() const { return dynamic_cast<AmgShiftedInverse *>(factorization.get()); }
      double                    shift = 0.;          // [rad^2/s^2]
      EigenSolution             eigen;
      bool                      coupled_constraints = false; // constrained entries must be filled in for output
      // The rigid-body motions the supports leave free, M-orthonormal, and M times each.
      std::vector<Vector<double>> rigid_modes, mass_times_rigid;
      mutable std::unique_ptr<space_parts::PointLocator> point_locator; // built on first use
      std::future<FillOrdering> fill_ordering; // start_fill_ordering's, until factorize_as_chosen
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
      supports = space_parts::apply_supports(scene, task, mapping, dof_handler, constraints,
                                             [this](const std::string &line) { summarize(line); });
      constraints.close();
      result.supports_summary = supports.summary(scene.supports);
      coupled_constraints     = has_coupling_constraints(constraints);
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
      std::vector<DoFHandler<3>::active_cell_iterator> cells;
      for (const auto &cell : dof_handler.active_cell_iterators())
        cells.push_back(cell);
      const auto moments = assembly::assemble_elasticity(scene, mapping, fe, quadrature, cells, supports.elastic_faces,
                                                            constraints, stiffness_matrix, mass_matrix);

      // distribute_local_to_global leaves a nonzero diagonal on constrained rows of both K and M,
      // which would be spurious eigenvalues K_ii / M_ii. With M_ii = 0 they move to infinity, where
      // shift-invert never finds them.
      for (const auto i : result.clamped_dofs)
        mass_matrix.set(i, i, 0.);
      result.n_spurious_rows = result.clamped_dofs.size();
      space_parts::set_mass_properties(moments, result);
    }

    solver_choice::Known SerialSpace::known_with_supports() const
    {
      solver_choice::Known known{space_parts::solver_settings(scene), /*distributed*/ false, {}, {}, {}};
      if (solver_choice::choose(known).needs == solver_choice::Needs::supports)
        known.free_motions = !supports.free_motions(Point<3>()).motions.empty();
      return known;
    }

    void SerialSpace::start_fill_ordering()
    {
      if (solver_choice::choose(known_with_supports()).factor == solver_choice::Factor::cholmod)
        fill_ordering = std::async(std::launch::async, [this] { return cholmod_fill_ordering(sparsity_pattern); });
    }

    // The solver choice (solver_choice.h) carried out: once the supports are known, CHOLMOD's analysis
    // against 'Modes/Factor memory limit' when the choice waits for it, then the factorization of
    // K - shift M it names (CHOLMOD or UMFPACK), none for LOBPCG + AMG or when it hands the space to MUMPS.
    void SerialSpace::factorize_as_chosen()
    {
      using solver_choice::Factor;
      solver_choice::Known known = known_with_supports();
      choice                     = solver_choice::choose(known);
      // The ordering started beside the assembly, if any (an empty one is computed by the factorization).
      const auto take_fill_ordering = [this] { return fill_ordering.valid() ? fill_ordering.get() : FillOrdering{}; };
      if (choice.factor == Factor::none && choice.needs == solver_choice::Needs::nothing)
        return;
      log("factorizing K (" + std::string(choice.factor == Factor::umfpack ? "UMFPACK" : "CHOLMOD") + ")");
      if (choice.needs == solver_choice::Needs::cholmod_analysis)
        {
          const double limit     = memory_budget_bytes(scene.modes.factor_memory_limit);
          double       predicted = 0.;
          factorization =
            make_cholmod_factorization_within(stiffness_matrix, &mass_matrix, shift, limit, predicted, take_fill_ordering());
          known.cholmod = solver_choice::CholmodAnalysis{predicted, limit};
          choice        = solver_choice::choose(known);
          Assert((factorization != nullptr) == (predicted <= limit), ExcInternalError());
          if (choice.backend == solver_choice::Backend::serial && !choice.log_line.empty())
            log(choice.log_line);
        }
      if (choice.factor == Factor::none || choice.backend != solver_choice::Backend::serial)
        return;
      if (!factorization)
        factorization = choice.factor == Factor::umfpack ?
                          make_umfpack_factorization(stiffness_matrix, &mass_matrix, shift) :
                          make_cholmod_factorization(stiffness_matrix, &mass_matrix, shift, take_fill_ordering());
      const auto &f = factorization->statistics();
      std::ostringstream line;
      line << "factor: " << f.factor_nonzeros << " nonzeros, analyze " << f.analyze_seconds << " s, factorize "
           << f.factorize_seconds << " s";
      log(line.str());
    }

    // LOBPCG + AMG (amg_eigensolver.h); its CG solves then stand in for the factorization's.
    EigenSolution SerialSpace::solve_with_lobpcg_amg()
    {
      std::optional<VertexSpaceTransfer> vertex_space;
      if (scene.element_degree > 1)
        vertex_space = make_vertex_space_transfer(dof_handler, mapping, constraints, MPI_COMM_SELF);
      auto amg = std::make_unique<AmgShiftedInverse>(stiffness_matrix, mass_matrix, shift,
                                                     rigid_body_motions(Point<3>()), result.clamped_dofs,
                                                     node_blocked(dof_handler, MPI_COMM_SELF),
                                                     vertex_space ? &*vertex_space : nullptr);
      std::ostringstream line;
      line << amg->preconditioner_name() << " set up in " << amg->statistics().analyze_seconds
           << " s; LOBPCG for " << space_parts::sought_modes(scene.modes);
      log(line.str());
      EigenSolution solution = amg->lowest_modes(scene.modes.maximum_count, scene.modes.lobpcg_tolerance,
                                                scene.modes.lobpcg_modes_per_run,
                                                [this](const std::string &line) { log(line); },
                                                space_parts::cut_off_stop(scene.modes));
      log("LOBPCG: " + std::to_string(amg->amg_statistics().eigensolver_iterations) + " iterations");
      factorization = std::move(amg);
      return solution;
    }

    void SerialSpace::solve_eigenproblem()
    {
      shift = space_parts::shift_eigenvalue(scene.modes);
      factorize_as_chosen();
      if (choice.backend != solver_choice::Backend::serial)
        return; // handed over: SpaceBase::run ends here
      using Method = solver_choice::Method;
      const Method method = choice.method;
      try
        {
          if (method == Method::lobpcg_amg)
            eigen = solve_with_lobpcg_amg();
          else if (method == Method::block_krylov)
            eigen = solve_block_shift_invert(mass_matrix, *factorization, shift, scene.modes.maximum_count,
                                             scene.modes.block_size, scene.modes.tolerance,
                                             memory_budget_bytes(scene.modes.factor_memory_limit), verbose,
                                             space_parts::cut_off_stop(scene.modes));
          else
            eigen = solve_shift_invert(stiffness_matrix, mass_matrix, *factorization, shift,
                                       scene.modes.maximum_count, scene.modes.tolerance, verbose,
                                       space_parts::cut_off_stop(scene.modes));
        }
      catch (const ExceptionBase &e)
        {
          if (method == Method::lobpcg_amg)
            throw;
          // Rigid-body modes (or nearly rigid ones, on soft elastic supports) are the shifted inverse's
          // largest eigenvalues, about 1 / |shift|: with a tiny shift they dwarf the elastic ones and
          // the block solver stalls (ARPACK does not).
          std::ostringstream message;
          e.print_info(message);
          const bool free = !supports.free_motions(Point<3>()).motions.empty();
          AssertThrow(false, ExcMessage(message.str() + (free ? " The part has free rigid-body motions: " :
                                                                " If the part is nearly free (soft elastic supports): ") +
                                        "a shift of larger magnitude (about a tenth of the first elastic frequency) or "
                                        "'Modes/Eigensolver = arpack' converges where a shift close to 0 does not."));
        }
      result.eigensolver_method =
        method == Method::lobpcg_amg ?
          amg_inverse()->eigensolver_method() :
        method == Method::block_krylov ?
          block_krylov_method(scene.modes.block_size, eigen) :
          "ARPACK dsaupd mode 3 (shift-invert)" + arpack_runs(eigen.n_runs);
      space_parts::record_iteration(result, eigen);
      identify_rigid_body_modes();
      // Rigid-body modes (lambda = 0) have no relative residual: theirs is taken against the first
      // elastic eigenvalue.
      result.self_check = check_eigenpairs(stiffness_matrix, mass_matrix, eigen.eigenvalues, eigen.eigenvectors,
                                           eigen.eigenvalues[result.n_rigid_body_modes]);
      std::ostringstream check;
      check << eigen.eigenvalues.size() << " modes in " << eigen.n_operator_applications << " solves, "
            << eigen.eigensolve_iteration_seconds << " s; f1 = " << std::sqrt(std::max(eigen.eigenvalues.front(), 0.)) / two_pi
            << " Hz; max |Phi^T M Phi - I| = " << result.self_check.orthonormality_error
            << ", max ||K phi - lambda M phi|| / ||lambda M phi|| = " << result.self_check.max_relative_residual
            << "; spurious eigenvalues: none below infinity (" << result.n_spurious_rows
            << " constrained rows have M_ii = 0)";
      log(check.str());
      select_modes();
    }

    // The nonlinear solves on this space's mesh, FE space, supports and sparsity (large_deformation.h);
    // its factorization of K (a direct one, with no shift) preconditions their tangent systems.
    nonlinear::SpaceView<nonlinear::SerialAlgebra> SerialSpace::validity_space()
    {
      Factorization *factor_of_K = (amg_inverse() == nullptr && shift == 0.) ? factorization.get() : nullptr;
      return {dof_handler, mapping,           quadrature,   constraints, sparsity_pattern, supports.elastic_faces,
              zero_field(), zero_field(), factor_of_K, scene.contact.validity_cg, &stiffness_matrix};
    }

    void SerialSpace::finish()
    {
      result.factorization = factorization->statistics();
      if (amg_inverse() == nullptr)
        return;
      const auto        &amg = amg_inverse()->amg_statistics();
      std::ostringstream line;
      line << "AMG-preconditioned block CG, deflated by " << amg.deflation_modes << " modes (" << amg.deflation_seconds
           << " s to set up): " << amg.n_cg_solves << " static solves (columns), " << amg.mean_cg_iterations
           << " block iterations on average, at most " << amg.max_cg_iterations << ", "
           << factorization->statistics().solve_seconds << " s";
      log(line.str());
    }

    void SerialSpace::select_modes()
    {
      std::vector<Vector<double>> kept;
      for (const unsigned int i : space_parts::select_modes(scene, eigen.eigenvalues, result))
        kept.push_back(std::move(eigen.eigenvectors[i]));
      eigen.eigenvectors = std::move(kept);
      summarize(space_parts::mode_selection_summary(scene, result));
      if (AmgShiftedInverse *amg = amg_inverse())
        amg->deflate_by_modes(eigen.eigenvectors);
    }

    // The n lowest computed modes of a part whose supports leave n rigid-body motions free (a
    // free-floating part: six) must span those motions (more zero-energy modes mean a mesh in pieces
    // or a mechanism). They are then replaced by the exact motions (lambda = 0, M-orthonormal) and the
    // elastic modes are made exactly M-orthogonal to them, so that no rigid drift hides in an elastic
    // mode and the kernel's omega = 0 modes are pure rigid motion.
    void SerialSpace::identify_rigid_body_modes()
    {
      const Point<3> centre(result.centre_of_mass[0], result.centre_of_mass[1], result.centre_of_mass[2]);
      const FreeMotions free = supports.free_motions(centre);
      if (free.motions.empty())
        return;
      rigid_modes.clear();
      mass_times_rigid.clear();
      for (auto &motion : free_motion_fields(free))
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
                  ExcMessage("Space '" + task.name + "': its supports leave " + std::to_string(n_rigid) +
                             " rigid-body motions free (" + free.describe() + "), but its " + std::to_string(n_rigid) +
                             " lowest modes (" + found.str() + " Hz; the next at " + std::to_string(first_elastic_hz) +
                             " Hz) are not those motions (M-distance " + std::to_string(result.rigid_subspace_sine) +
                             "). A mesh in several pieces or a mechanism has more zero-energy modes: check the "
                             "geometry and the supports ('Geometry/Supports')."));
      for (unsigned int i = 0; i < phi.size(); ++i)
        if (i < n_rigid)
          phi[i] = rigid_modes[i], lambda[i] = 0.;
        else
          {
            remove_rigid_motion(phi[i].begin());
            phi[i] /= std::sqrt(mass_matrix.matrix_norm_square(phi[i]));
          }
      result.n_rigid_body_modes = n_rigid;
      result.free_motions       = free.describe();
      std::ostringstream line;
      line << n_rigid << " free rigid-body motions (" << result.free_motions << "): the lowest modes (computed"
           << found.str() << " Hz, M-distance from the exact motions " << result.rigid_subspace_sine
           << "), replaced by the exact motions at 0 Hz; first elastic mode " << first_elastic_hz << " Hz";
      log(line.str());
    }

    // The free motions as DoF fields, zero on the constrained DoFs (as every field of the constrained
    // system): a free motion satisfies the constraints, so it is filled in exactly for output.
    std::vector<Vector<double>> SerialSpace::free_motion_fields(const FreeMotions &free) const
    {
      std::vector<Point<3>> support(dof_handler.n_dofs());
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      const auto                  component = dof_components();
      std::vector<Vector<double>> fields;
      for (unsigned int m = 0; m < free.motions.size(); ++m)
        {
          Vector<double> field(dof_handler.n_dofs());
          for (types::global_dof_index i = 0; i < dof_handler.n_dofs(); ++i)
            if (!constraints.is_constrained(i))
              field[i] = free.displacement(m, support[i])[component[i]];
          fields.push_back(std::move(field));
        }
      return fields;
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
      Vector<double>     u(n), K_u(n);
      const unsigned int steps = space_parts::refine_static_solve(
        [&] {
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
          return worst;
        },
        task.name, scene.modes.shift);
      result.static_solve_iterations = std::max(result.static_solve_iterations, steps);
    }

    const space_parts::PointLocator &SerialSpace::locator() const
    {
      if (!point_locator)
        point_locator = std::make_unique<space_parts::PointLocator>(triangulation, mapping);
      return *point_locator;
    }

    // Every cell is this process's: each point is located in the whole mesh, the points split between
    // deal.II's threads (the locator only reads once its search tree is built: by the first point).
    std::vector<space_parts::EvaluationPoint>
    SerialSpace::evaluation_points(const std::vector<meshing::Point3> &points, double *max_outside) const
    {
      std::vector<space_parts::EvaluationPoint> evaluated(points.size());
      std::vector<double>                       outside(points.size(), 0.);
      const auto locate = [&](const std::size_t first, const std::size_t last) {
        for (std::size_t k = first; k < last; ++k)
          {
            const auto located = locator().locate(points[k]);
            outside[k]         = located.distance_outside;
            evaluated[k]       = {DoFHandler<3>::active_cell_iterator(&triangulation, located.cell->level(),
                                                                 located.cell->index(), &dof_handler),
                            located.unit};
          }
      };
      if (points.empty())
        return evaluated;
      locate(0, 1);
      parallel::apply_to_subranges(std::size_t(1), points.size(), locate, 256);
      if (max_outside)
        *max_outside = std::max(*max_outside, *std::max_element(outside.begin(), outside.end()));
      return evaluated;
    }

    SerialSpace::Field SerialSpace::patch_load(const unsigned int vertex, const std::array<double, 3> &factor) const
    {
      Field load = zero_field();
      surface.add_patch_load(vertex, factor, load);
      return load;
    }

    // The fields as one block of columns: one pass over the factor for all of them.
    void SerialSpace::solve_static(std::vector<Field> &fields)
    {
      const std::size_t   n = dof_handler.n_dofs();
      std::vector<double> columns(n * fields.size());
      for (std::size_t k = 0; k < fields.size(); ++k)
        std::copy(fields[k].begin(), fields[k].end(), columns.begin() + k * n);
      solve_static(columns.data(), fields.size());
      for (std::size_t k = 0; k < fields.size(); ++k)
        std::copy(columns.begin() + k * n, columns.begin() + (k + 1) * n, fields[k].begin());
    }

    // W^T K^-1 W of groups of loads from the factorization when it is a factor of K itself (no shift
    // to refine against, no inertia relief to apply) and can give it (CHOLMOD's).
    bool SerialSpace::group_grams(const std::vector<ContactGroup> &groups, std::vector<std::vector<double>> &grams)
    {
      if (shift != 0. || !rigid_modes.empty())
        return false;
      // A halo vertex is a member of a later group: its three columns are borrowed from there, wanted
      // with the members it is a neighbour of.
      std::map<unsigned int, std::pair<std::size_t, std::size_t>> member_column; // vertex -> (group, first column)
      for (std::size_t g = 0; g < groups.size(); ++g)
        for (unsigned int m = 0; m < groups[g].n_members; ++m)
          member_column[groups[g].vertices[m]] = {g, 3 * m};
      std::vector<GramGroup> columns(groups.size());
      for (std::size_t g = 0; g < groups.size(); ++g)
        {
          const auto &group = groups[g];
          for (unsigned int m = 0; m < group.n_members; ++m)
            for (const auto &direction : surface.patch_loads.at(group.vertices[m]))
              columns[g].columns.emplace_back(direction.begin(), direction.end());
          for (unsigned int h = 0; h < group.halo_neighbours_of.size(); ++h)
            {
              std::vector<std::size_t> wanted;
              for (const unsigned int m : group.halo_neighbours_of[h])
                for (std::size_t d = 0; d < 3; ++d)
                  wanted.push_back(3 * m + d);
              const auto [lender, first] = member_column.at(group.vertices[group.n_members + h]);
              for (std::size_t d = 0; d < 3; ++d)
                {
                  columns[g].borrowed.emplace_back(lender, first + d);
                  columns[g].wanted.push_back(wanted);
                }
            }
        }
      return factorization->group_grams(columns, grams);
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
      std::vector<Field> filled_in; // with coupling constraints: the constrained entries' values
      if (coupled_constraints)
        for (const auto &mode : eigen.eigenvectors)
          filled_in.push_back(output_field(mode));
      const auto &modes = coupled_constraints ? filled_in : eigen.eigenvectors;
      result.modes_at_vertices.assign(std::size_t(r) * result.n_vertices * 3, 0.);
      for (const auto &cell : dof_handler.active_cell_iterators())
        for (unsigned int vtx = 0; vtx < 4; ++vtx)
          for (unsigned int c = 0; c < 3; ++c)
            {
              const auto dof = cell->vertex_dof_index(vtx, c);
              for (unsigned int i = 0; i < r; ++i)
                result.modes_at_vertices[(std::size_t(i) * result.n_vertices + cell->vertex_index(vtx)) * 3 + c] =
                  modes[i][dof];
            }
    }

    std::vector<unsigned int> SerialSpace::dof_components() const
    {
      std::vector<unsigned int>            component(dof_handler.n_dofs());
      std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
      for (const auto &cell : dof_handler.active_cell_iterators())
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            component[dofs[i]] = fe.system_to_component_index(i).first;
        }
      return component;
    }

    // Translations along x, y, z, then rotations about the axes through 'centre', as DoF fields: the
    // FE space holds them exactly (they are linear). Clamped DoFs keep their motion: M's clamped rows
    // are zero, so they add nothing to M-products.
    std::array<Vector<double>, 6> SerialSpace::rigid_body_motions(const Point<3> &centre) const
    {
      std::vector<Point<3>> support(dof_handler.n_dofs());
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      const auto component = dof_components();
      std::array<Vector<double>, 6> motions;
      for (unsigned int k = 0; k < 6; ++k)
        {
          motions[k].reinit(dof_handler.n_dofs());
          for (types::global_dof_index i = 0; i < dof_handler.n_dofs(); ++i)
            motions[k][i] = rigid_body_motion(k, support[i] - centre)[component[i]];
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

    // The space computed by MUMPS on this one process, as the solver choice handed it over: the
    // distributed backend on MPI_COMM_SELF (as --distributed runs it), its rows then put in the
    // serial result's mesh order.
    ModalSpaceResult compute_with_mumps_on_this_process(const SceneParameters &scene, const ContactSurface &display,
                                                        const SpaceTask &task, const std::string &vtu_file,
                                                        TimerOutput &timer, const bool verbose,
                                                        const solver_choice::Choice &hand_over)
    {
      if (verbose)
        std::cout << "[" << task.name << "] " << hand_over.log_line << std::endl;
      ModalSpaceResult result =
        compute_modal_space_distributed(scene, display, task, vtu_file, timer, verbose, MPI_COMM_SELF);
      gather_rows_on_root(result, MPI_COMM_SELF);
      result.eigensolver_method += hand_over.report_note;
      return result;
    }
  } // namespace

  ModalSpaceResult compute_modal_space(const SceneParameters &scene,
                                       const ContactSurface  &display,
                                       const SpaceTask       &task,
                                       const std::string     &vtu_file,
                                       TimerOutput           &timer,
                                       const bool             verbose)
  {
    // What the parameters alone decide, before assembly ('Factor storage = disk': MUMPS's).
    const solver_choice::Choice before_assembly =
      solver_choice::choose({space_parts::solver_settings(scene), /*distributed*/ false, {}, {}, {}});
    if (before_assembly.backend == solver_choice::Backend::mumps_on_this_process)
      return compute_with_mumps_on_this_process(scene, display, task, vtu_file, timer, verbose, before_assembly);
    Timer                 serial_attempt;
    solver_choice::Choice hand_over;
    {
      SerialSpace space(scene, display, task, vtu_file, timer, verbose);
      auto        outcome = space.run();
      if (auto *result = std::get_if<ModalSpaceResult>(&outcome))
        return std::move(*result);
      hand_over = std::get<solver_choice::Choice>(outcome);
    }
    // The serial assembly and CHOLMOD's analysis were spent before the choice (seconds against the
    // minutes of a factor that does not fit in memory); the report keeps them apart.
    const double     spent  = serial_attempt.wall_time();
    ModalSpaceResult result = compute_with_mumps_on_this_process(scene, display, task, vtu_file, timer, verbose, hand_over);
    result.timings_s["serial_attempt"] = spent;
    return result;
  }
} // namespace modal_haptics
