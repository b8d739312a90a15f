#include "space/distributed_space.h"

#include "solvers/amg_eigensolver.h"
#include "solvers/mumps_inverse.h"

#include "space/distributed_block_operators.h"
#include "space/phased_space.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/fully_distributed_tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria_description.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/parpack_solver.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_sparsity_pattern.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/numerics/data_out.h>

#include <Epetra_CrsMatrix.h>
#include <Epetra_MultiVector.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    constexpr double two_pi = 2. * M_PI;
    using DistributedVector = TrilinosWrappers::MPI::Vector;

    // The distributed backend of the space phases (space/phase_*.h): a fully distributed mesh,
    // Trilinos matrices, MUMPS for the static solves and the shift-invert operator, the block
    // Krylov eigensolver (or PARPACK, 'Modes/Eigensolver = arpack').
    class DistributedSpace : public space_phases::PhasedSpace<DistributedSpace>
    {
    public:
      DistributedSpace(const SceneParameters &scene, const ContactSurface &display, const SpaceTask &task,
                       const std::string &vtu_file, TimerOutput &timer, bool verbose, MPI_Comm comm);

      // The backend of the phases (space/backend.h).
      using Field = DistributedVector;
      struct Block
      {
        std::vector<DistributedVector> columns; // loads, then (solve_static) the ghosted solutions
      };
      const std::vector<Field> &kept_modes() const { return modes; }
      const std::vector<Field> &ghosted_kept_modes() const { return ghosted_modes; }
      Field ghosted(const Field &owned) const;
      Field zero_field() const { return owned_layout; }
      // Collective: every point is evaluated by one process, the one whose own cells hold it best (the
      // serial locator's rule, space_parts::PointLocator, ties to the lowest rank); the others get an
      // invalid cell. 'max_outside', if given, is the farthest a point lies outside the mesh.
      std::vector<space_parts::EvaluationPoint> evaluation_points(const std::vector<meshing::Point3> &points,
                                                                  double *max_outside) const;
      // sum_d factor_d W_v e_d as a distributed vector; each process adds its cells' part.
      Field patch_load(unsigned int vertex, const std::array<double, 3> &factor) const;
      // The nonlinear solves on this space's own cells and supports (large_deformation.h); MUMPS's
      // factorization of K (with no shift) preconditions their tangent systems.
      nonlinear::SpaceView<nonlinear::DistributedAlgebra> validity_space()
      {
        DistributedInverse *factor_of_K = (amg == nullptr && shift == 0.) ? inverse.get() : nullptr;
        return {dof_handler,  mapping,        quadrature,  constraints,
                stiffness_matrix, supports.elastic_faces, owned_layout, ghosted_layout,
                factor_of_K,  scene.contact.validity_cg, &stiffness_matrix};
      }
      // A free-floating part is refused before assembly (setup_system): no load needs relief.
      void relieve_load(Field &) const {}
      Block new_block(unsigned int) const { return {}; }
      void add_patch_loads(Block &X, unsigned int first_column, unsigned int vertex) const;
      void add_combined_patch_loads(Block &X, const std::vector<const space_parts::DofWeights *> &rows,
                                    const double *weights, unsigned int count) const;
      void patch_row_averages(const Block &X, const std::vector<const space_parts::DofWeights *> &rows,
                              const unsigned int count, double *averages) const
      {
        for (unsigned int j = 0; j < count; ++j)
          surface.row_averages(rows, block_column(X, j), averages + j * rows.size());
      }
      void solve_static(Block &X);
      unsigned int columns_per_static_solve(const unsigned int wanted) const
      {
        return amg ? amg->columns_fitting_one_solve(wanted) : wanted;
      }
      void solve_static(std::vector<Field> &fields);
      // MUMPS and the AMG solve every load (phase_static_correction.h then solves in blocks).
      bool group_grams(const std::vector<ContactGroup> &, std::vector<std::vector<double>> &) const
      {
        return false;
      }
      const Field &block_column(const Block &X, const unsigned int column) const { return X.columns[column]; }
      void sum_over_processes(std::vector<double> &values) const;
      void condense(space_parts::DofWeights &weights) const { condense_weights(constraints, weights); }
      Field output_field(const Field &u) const;
      std::array<Field, 6> rigid_body_motions(const Point<3> &centre) const;
      void fill_modes_at_vertices();
      void write_vtu(space_phases::VtuOutput &data_out) const { data_out.write_vtu_in_parallel(vtu_file, comm); }

      DoFHandler<3>                    dof_handler;
      TrilinosWrappers::SparseMatrix   stiffness_matrix, mass_matrix;
      space_phases::SurfaceOperators   surface;
      std::vector<Field>               validation_fields; // full - modal, ghosted
      using SpaceBase::mapping;

    private:
      void assemble() override
      {
        read_and_partition_mesh();
        setup_system();
        assemble_system();
      }
      void solve_eigenproblem() override;
      void finish() override
      {
        if (amg)
          result.factorization = amg->statistics();
      }
      std::map<types::global_dof_index, unsigned int> dof_components() const;
      bool factorize_as_chosen();
      void refuse_shift_above_first_mode() const;
      void block_krylov_modes(std::vector<double> &eigenvalues, std::vector<DistributedVector> &eigenvectors);
      void parpack_modes(std::vector<double> &eigenvalues, std::vector<DistributedVector> &eigenvectors);
      DistributedVector distributed(const dealii::Vector<double> &local) const;
      void lobpcg_amg_modes(std::vector<double> &eigenvalues, std::vector<DistributedVector> &eigenvectors);
      // columns[c] = A^-1 columns[c], all at once: one MUMPS solve of the block, or one block CG.
      void apply_inverse(std::vector<DistributedVector> &columns)
      {
        if (amg)
          amg->solve_columns(columns);
        else
          inverse->solve_columns(columns);
      }

      void read_and_partition_mesh();
      void setup_system();
      void assemble_system();

      const MPI_Comm comm;

      // Every process reads the whole mesh to partition it, then keeps only its share: the whole mesh
      // is gone before the matrices exist (docs/cluster.md).
      parallel::fullydistributed::Triangulation<3> triangulation;
      std::vector<unsigned int>                    whole_mesh_vertex;  // by local vertex index, of own and ghost cells
      std::vector<std::array<types::global_dof_index, 3>> owned_vertex_dofs; // of result.owned_rows->vertices
      IndexSet                                     owned_dofs, relevant_dofs;
      // The layouts new vectors copy: a copy shares the Epetra maps, and with them the directory
      // Epetra builds once per map for its imports and exports; a vector made from the IndexSets
      // builds both anew, a collective step per vector (a sixth of the static correction at np = 2).
      DistributedVector owned_layout, ghosted_layout, writable_layout;
      AffineConstraints<double>                    constraints;
      bool                                         coupled_constraints = false; // on any process
      double                                       shift = 0.; // MUMPS factorizes K - shift M [1/s^2]
      TrilinosWrappers::SparseMatrix               shifted_matrix;
      std::unique_ptr<DistributedInverse>          inverse;
      std::unique_ptr<AmgShiftedInverse>           amg; // instead of 'inverse' with Eigensolver = lobpcg-amg
      std::vector<DoFHandler<3>::active_cell_iterator> owned_cells;
      std::unique_ptr<space_parts::PointLocator>   locator; // in the owned cells
      std::vector<DistributedVector>               modes, ghosted_modes;        // kept, M-orthonormal
    };

    DistributedSpace::DistributedSpace(const SceneParameters &scene, const ContactSurface &display,
                                                 const SpaceTask &task, const std::string &vtu_file, TimerOutput &timer,
                                                 const bool verbose,
                                                 const MPI_Comm comm)
      : PhasedSpace(scene, display, task, vtu_file, timer, verbose)
      , comm(comm)
      , triangulation(comm)
    {}

    // The FACTS recipe: every process reads the serial mesh, partitions it (METIS, deterministic) and
    // builds its part of the fully distributed mesh; material and boundary ids carry over. A coarse
    // cell keeps its whole-mesh index as its id: what this process needs of the whole mesh (the
    // whole-mesh numbers of its vertices, its tets for the HDF5 file) is taken from it here, and the
    // whole mesh is freed.
    void DistributedSpace::read_and_partition_mesh()
    {
      {
        Triangulation<3> whole_mesh;
        space_parts::read_mesh(scene, task, whole_mesh, result);
        GridTools::partition_triangulation(Utilities::MPI::n_mpi_processes(comm), whole_mesh);
        triangulation.create_triangulation(
          TriangulationDescription::Utilities::create_description_from_triangulation(whole_mesh, comm));
        result.owned_rows.emplace();
        std::vector<unsigned int> tets;
        whole_mesh_vertex.assign(triangulation.n_vertices(), numbers::invalid_unsigned_int);
        for (const auto &cell : triangulation.active_cell_iterators())
          if (!cell->is_artificial())
            {
              const unsigned int index = cell->id().get_coarse_cell_id();
              const Triangulation<3>::active_cell_iterator whole_cell(&whole_mesh, 0, index);
              for (unsigned int v = 0; v < 4; ++v)
                whole_mesh_vertex[cell->vertex_index(v)] = whole_cell->vertex_index(v);
              if (cell->is_locally_owned())
                {
                  result.owned_rows->tets.push_back(index);
                  for (unsigned int v = 0; v < 4; ++v)
                    tets.push_back(whole_cell->vertex_index(v));
                }
            }
        result.mesh_tets = std::move(tets);
        result.mesh_vertices.clear();
        result.mesh_vertices.shrink_to_fit();
      }
      locator = std::make_unique<space_parts::PointLocator>(triangulation, mapping);
    }

    void DistributedSpace::setup_system()
    {
      dof_handler.reinit(triangulation);
      dof_handler.distribute_dofs(fe);
      result.n_dofs = dof_handler.n_dofs();
      owned_dofs    = dof_handler.locally_owned_dofs();
      DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);
      owned_layout.reinit(owned_dofs, comm);
      ghosted_layout.reinit(owned_dofs, relevant_dofs, comm);
      writable_layout.reinit(owned_dofs, relevant_dofs, comm, /*vector_writable*/ true);

      for (const auto &cell : dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
          owned_cells.push_back(cell);

      // The vertices whose DoFs this process owns are its rows of the mesh vertices and the modes
      // there, in whole-mesh order.
      std::map<unsigned int, std::pair<Point<3>, std::array<types::global_dof_index, 3>>> owned_vertices;
      for (const auto &cell : owned_cells)
        for (unsigned int v = 0; v < 4; ++v)
          if (owned_dofs.is_element(cell->vertex_dof_index(v, 0)))
            owned_vertices[whole_mesh_vertex[cell->vertex_index(v)]] = {
              cell->vertex(v), {{cell->vertex_dof_index(v, 0), cell->vertex_dof_index(v, 1), cell->vertex_dof_index(v, 2)}}};
      whole_mesh_vertex = std::vector<unsigned int>();
      for (const auto &[index, vertex] : owned_vertices)
        {
          result.owned_rows->vertices.push_back(index);
          for (unsigned int d = 0; d < 3; ++d)
            result.mesh_vertices.push_back(vertex.first[d]);
          owned_vertex_dofs.push_back(vertex.second);
        }

      constraints.clear();
      constraints.reinit(relevant_dofs);
      supports = space_parts::apply_supports(scene, task, mapping, dof_handler, constraints,
                                             [this](const std::string &line) { summarize(line); }, comm);
      constraints.close();
      result.supports_summary = supports.summary(scene.supports);
      coupled_constraints     = Utilities::MPI::max(int(has_coupling_constraints(constraints)), comm) > 0;
      // The phases (space/phase_*.h) would handle free motions as the serial path does, by inertia
      // relief (relieve_load) and static_gain; what this backend lacks is the eigensolve's side: the
      // identification of the rigid-body modes against the exact free motions, and static solves
      // that keep their answers M-orthogonal to them.
      const FreeMotions free = supports.free_motions(Point<3>(), comm);
      choice = solver_choice::choose({space_parts::solver_settings(scene), /*distributed*/ true,
                                      !free.motions.empty(), {}, {}});
      AssertThrow(choice.refusal.empty(),
                  ExcMessage(free.motions.empty() ?
                               choice.refusal :
                               "Space '" + task.name + "': the supports leave " + std::to_string(free.motions.size()) +
                                 " rigid-body motions free (" + free.describe() + "); " + choice.refusal));
      std::vector<unsigned int> clamped;
      for (const auto i : owned_dofs)
        if (constraints.is_constrained(i))
          clamped.push_back(i);
      for (const auto &part : Utilities::MPI::all_gather(comm, clamped))
        result.clamped_dofs.insert(result.clamped_dofs.end(), part.begin(), part.end());
      std::sort(result.clamped_dofs.begin(), result.clamped_dofs.end());
      result.n_clamped_dofs = result.clamped_dofs.size();

      TrilinosWrappers::SparsityPattern sparsity(owned_dofs, owned_dofs, relevant_dofs, comm);
      DoFTools::make_sparsity_pattern(dof_handler, sparsity, constraints, /*keep_constrained_dofs*/ false,
                                      Utilities::MPI::this_mpi_process(comm));
      sparsity.compress();
      stiffness_matrix.reinit(sparsity);
      mass_matrix.reinit(sparsity);
      log(std::to_string(result.n_cells) + " tets, " + std::to_string(result.n_vertices) + " vertices, " +
          std::to_string(result.n_dofs) + " DoFs (P" + std::to_string(scene.element_degree) + "), " +
          std::to_string(result.n_clamped_dofs) + " clamped, on " +
          std::to_string(Utilities::MPI::n_mpi_processes(comm)) + " process(es)");
    }

    void DistributedSpace::assemble_system()
    {
      const auto moments = assembly::assemble_elasticity(scene, mapping, fe, quadrature, owned_cells,
                                                            supports.elastic_faces, constraints, stiffness_matrix,
                                                            mass_matrix);
      stiffness_matrix.compress(VectorOperation::add);
      mass_matrix.compress(VectorOperation::add);

      // As in the serial space: M_ii = 0 on constrained rows moves their spurious eigenvalues
      // K_ii / M_ii to infinity.
      for (const auto i : owned_dofs)
        if (constraints.is_constrained(i))
          mass_matrix.set(i, i, 0.);
      mass_matrix.compress(VectorOperation::insert);
      result.n_spurious_rows = result.n_clamped_dofs;
      space_parts::set_mass_properties(moments, result, [&](const double x) { return Utilities::MPI::sum(x, comm); });
    }

    // The solver choice (solver_choice.h) carried out: MUMPS factorizes K - shift M for the eigensolver
    // and the static solves, its factor in memory or on disk as the choice says once MUMPS's analysis
    // has predicted what it needs against 'Modes/Factor memory limit' (shared by the processes of a
    // node, half the node's available memory by default); or nothing is factorized (LOBPCG + AMG).
    // Returns whether it factorized (collective: every process decides alike).
    bool DistributedSpace::factorize_as_chosen()
    {
      solver_choice::Known known{space_parts::solver_settings(scene), /*distributed*/ true,
                                 /*free_motions (refused in setup_system)*/ false, {}, {}};
      choice = solver_choice::choose(known);
      if (choice.needs != solver_choice::Needs::mumps_analysis)
        return false;
      if (!choice.log_line.empty())
        log(choice.log_line);
      log(std::string("factorizing K with MUMPS (") +
          (choice.factor == solver_choice::Factor::mumps_lu ? "LU, Trilinos Amesos_Mumps" : "symmetric") + ")");
      if (shift != 0.)
        {
          shifted_matrix.copy_from(stiffness_matrix);
          shifted_matrix.add(-shift, mass_matrix);
        }
      const auto        &A           = shift != 0. ? shifted_matrix : stiffness_matrix;
      const unsigned int on_node     = processes_on_this_node(comm);
      const double       per_process = memory_budget_per_process_bytes(scene.modes.factor_memory_limit, comm);
      const auto place = [&](const solver_choice::MumpsPrediction &predicted) {
        known.mumps = solver_choice::MumpsAnalysis{predicted, per_process, on_node};
        choice      = solver_choice::choose(known);
        log(choice.log_line);
        return choice.placement;
      };
      inverse = make_mumps_inverse(A, scene.modes.distributed_factorization, shift <= 0., scene.modes.factor_directory,
                                   result.factorization, place);
      return inverse != nullptr;
    }

    // The inertia of MUMPS's L D L^T (Sylvester): a negative eigenvalue of K - shift M is a mode
    // below the shift, found here before any iteration (with the LU, solve_eigenproblem finds it
    // among the computed modes).
    void DistributedSpace::refuse_shift_above_first_mode() const
    {
      const long below_shift = inverse->negative_eigenvalues();
      AssertThrow(below_shift <= 0,
                  ExcMessage("'Modes/Shift' (" + std::to_string(scene.modes.shift) + " Hz) lies above " +
                             std::to_string(below_shift) + (below_shift == 1 ? " eigenfrequency" : " eigenfrequencies") +
                             " of space '" + task.name +
                             "' (the inertia of MUMPS's L D L^T of K - shift*M): K - shift*M is not positive "
                             "definite. Choose a shift below the first frequency."));
    }

    // This process's rows as a distributed vector.
    DistributedVector DistributedSpace::distributed(const dealii::Vector<double> &local) const
    {
      DistributedVector v = owned_layout;
      std::copy(local.begin(), local.end(), v.trilinos_vector()[0]);
      return v;
    }

    // The serial path's block Krylov iteration (block_eigensolver.cc) over MUMPS's block solves.
    void DistributedSpace::block_krylov_modes(std::vector<double>            &eigenvalues,
                                              std::vector<DistributedVector> &eigenvectors)
    {
      DistributedBlockOperators operators(mass_matrix, *inverse, owned_layout, comm);
      const double memory_limit = memory_budget_per_process_bytes(scene.modes.factor_memory_limit, comm);
      const EigenSolution solution = solve_block_shift_invert(operators, shift, scene.modes.maximum_count,
                                                              scene.modes.block_size, scene.modes.tolerance,
                                                              memory_limit, verbose,
                                                              space_parts::cut_off_stop(scene.modes));
      space_parts::record_iteration(result, solution);
      result.eigensolver_method = block_krylov_method(scene.modes.block_size, solution) + ", distributed";
      eigenvalues = solution.eigenvalues;
      for (const auto &local : solution.eigenvectors)
        eigenvectors.push_back(distributed(local));
    }

    // PARPACK in mode 3 (shift-invert, M inner product) over the MUMPS factorization, in runs until
    // the cut-off decides the count, as the serial ARPACK (eigensolver.cc, solve_shift_invert, says
    // why that is safe: the shift lies below the first mode, which MUMPS's inertia confirmed in
    // refuse_shift_above_first_mode, or the LU path's check after the solve does). The inertia
    // counts modes below the factorized shift only: a Sylvester count below the cut-off would take
    // a second factorization, of K - cut-off M, which is not done. The start vector is a fixed
    // function of the DoF positions, not of their numbering or partition, so that runs on different
    // process counts build nearly the same Krylov space.
    void DistributedSpace::parpack_modes(std::vector<double> &eigenvalues, std::vector<DistributedVector> &eigenvectors)
    {
      const int          n       = result.n_dofs;
      const unsigned int n_modes = scene.modes.maximum_count;
      AssertThrow(n_modes >= 1 && int(n_modes) < n - 1,
                  ExcMessage("Cannot compute " + std::to_string(n_modes) + " modes of a system with " + std::to_string(n) +
                             " unknowns: lower 'Modes/Maximum number of modes' or refine the mesh."));

      std::map<types::global_dof_index, Point<3>> support;
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      DistributedVector start = owned_layout;
      for (const auto i : owned_dofs)
        {
          const Point<3> &x = support.at(i);
          start[i]          = constraints.is_constrained(i) ? 0. : 1. + 0.5 * std::sin(1e3 * (x[0] + 2. * x[1] + 3. * x[2]) + i % 3);
        }
      start.compress(VectorOperation::insert);

      // PARPACK's operator: MUMPS's solve, then the projection onto the complement of the modes found
      // by the earlier runs (nothing in the first).
      FoundModes<DistributedVector> found;
      struct ComplementInverse
      {
        const DistributedInverse            &inverse;
        const FoundModes<DistributedVector> &found;
        void vmult(DistributedVector &dst, const DistributedVector &src) const
        {
          inverse.vmult(dst, src);
          found.project(dst);
        }
      } const operator_in_complement{*inverse, found};
      const CutOffStop stop = space_parts::cut_off_stop(scene.modes);
      Timer            arpack_timer;
      unsigned int     runs = 0;
      for (unsigned int nev = stop.next_batch({}, n_modes); nev > 0; nev = stop.next_batch(found.ascending(), n_modes))
        {
          if (runs++ > 0)
            log("PARPACK: the " + std::to_string(found.size()) + " modes found do not decide the cut-off's count: " +
                std::to_string(nev) + " more, in their M-orthogonal complement");
          const unsigned int ncv = std::min(n - 1, std::max(2 * int(nev) + 10, 20)); // as the serial ARPACK call
          SolverControl      control(10000, scene.modes.tolerance, false, false);
          PArpackSolver<DistributedVector> solver(
            control, comm,
            PArpackSolver<DistributedVector>::AdditionalData(ncv, PArpackSolver<DistributedVector>::largest_magnitude,
                                                             /*symmetric*/ true, /*mode*/ 3));
          solver.reinit(owned_dofs);
          solver.set_shift(shift);
          solver.set_initial_vector(start);
          std::vector<std::complex<double>> lambda(nev);
          std::vector<DistributedVector>    vectors(nev, owned_layout);
          solver.solve(stiffness_matrix, mass_matrix, operator_in_complement, lambda, vectors, nev);
          for (unsigned int i = 0; i < nev; ++i)
            found.add(lambda[i].real(), std::move(vectors[i]), mass_matrix);
        }
      result.eigensolve_iteration_seconds = arpack_timer.wall_time();
      result.n_operator_applications      = result.factorization.n_solved_vectors;
      result.eigensolver_method = "PARPACK pdsaupd mode 3 (shift-invert)" + arpack_runs(runs) + ", distributed";
      found.take_ascending(eigenvalues, eigenvectors);
    }

    // LOBPCG + AMG on this backend's Trilinos matrices (amg_eigensolver.h), every process its rows.
    void DistributedSpace::lobpcg_amg_modes(std::vector<double> &eigenvalues, std::vector<DistributedVector> &eigenvectors)
    {
      const auto motions       = rigid_body_motions(Point<3>());
      const std::size_t         n_local = owned_dofs.n_elements();
      std::vector<double>       near_null_space(6 * n_local);
      std::vector<unsigned int> constrained;
      for (std::size_t k = 0; k < n_local; ++k)
        {
          const auto i = owned_dofs.nth_index_in_set(k);
          for (unsigned int j = 0; j < 6; ++j)
            near_null_space[j * n_local + k] = motions[j][i];
          if (constraints.is_constrained(i))
            constrained.push_back(k);
        }
      std::optional<VertexSpaceTransfer> vertex_space;
      if (scene.element_degree > 1)
        vertex_space = make_vertex_space_transfer(dof_handler, mapping, constraints, comm);
      amg = std::make_unique<AmgShiftedInverse>(stiffness_matrix, mass_matrix, shift, std::move(near_null_space),
                                                constrained, node_blocked(dof_handler, comm),
                                                vertex_space ? &*vertex_space : nullptr);
      log(amg->preconditioner_name() + " set up; LOBPCG for " + space_parts::sought_modes(scene.modes) +
          ", distributed");
      Timer timer;
      EigenSolution solution = amg->lowest_modes(scene.modes.maximum_count, scene.modes.lobpcg_tolerance,
                                                scene.modes.lobpcg_modes_per_run,
                                                [this](const std::string &line) { log(line); },
                                                space_parts::cut_off_stop(scene.modes));
      result.eigensolve_iteration_seconds = timer.wall_time();
      result.n_operator_applications      = solution.n_operator_applications;
      result.eigensolver_method           = amg->eigensolver_method() + ", distributed";
      eigenvalues = solution.eigenvalues;
      for (const auto &local : solution.eigenvectors)
        eigenvectors.push_back(distributed(local));
    }

    void DistributedSpace::solve_eigenproblem()
    {
      shift = space_parts::shift_eigenvalue(scene.modes);
      std::vector<double>            eigenvalues;
      std::vector<DistributedVector> eigenvectors;
      if (!factorize_as_chosen())
        lobpcg_amg_modes(eigenvalues, eigenvectors);
      else
        {
          refuse_shift_above_first_mode();
          if (choice.method == solver_choice::Method::arpack)
            parpack_modes(eigenvalues, eigenvectors);
          else
            block_krylov_modes(eigenvalues, eigenvectors);
        }

      // MUMPS's LU factorizes an indefinite K - shift M too, where the serial Cholesky refuses it: a
      // mode below the shift says that the shift lies above the first eigenfrequency (the
      // symmetric mode's inertia said so before the iteration).
      AssertThrow(eigenvalues.front() > shift,
                  ExcMessage("'Modes/Shift' (" + std::to_string(scene.modes.shift) + " Hz) lies above the first "
                             "eigenfrequency (" + std::to_string(std::sqrt(std::max(eigenvalues.front(), 0.)) / two_pi) +
                             " Hz): K - shift*M is not positive definite. Choose a shift below the first frequency."));
      result.self_check = check_eigenpairs(stiffness_matrix, mass_matrix, eigenvalues, eigenvectors);
      for (const unsigned int i : space_parts::select_modes(scene, eigenvalues, result))
        {
          ghosted_modes.push_back(ghosted(eigenvectors[i]));
          modes.push_back(std::move(eigenvectors[i]));
        }
      if (amg)
        amg->deflate_by_modes(modes);
      std::ostringstream line;
      line << eigenvalues.size() << " modes in " << result.n_operator_applications << " solves, "
           << result.eigensolve_iteration_seconds << " s; f1 = " << result.computed_frequencies_hz.front()
           << " Hz; max |Phi^T M Phi - I| = " << result.self_check.orthonormality_error
           << ", max ||K phi - lambda M phi|| / ||lambda M phi|| = " << result.self_check.max_relative_residual
           << "; kept " << modes.size();
      log(line.str());
      summarize(space_parts::mode_selection_summary(scene, result));
    }

    std::vector<space_parts::EvaluationPoint>
    DistributedSpace::evaluation_points(const std::vector<meshing::Point3> &points, double *max_outside) const
    {
      struct Claim // MPI_DOUBLE_INT
      {
        double closeness; // minus the distance outside the owned cells
        int    rank;
      };
      // The serial locator tries the cells of the n nearest boxes of the whole mesh: the n nearest
      // over all processes are those within the n-th smallest distance of every process's n nearest.
      constexpr unsigned int n    = space_parts::PointLocator::n_nearest;
      const int              rank = Utilities::MPI::this_mpi_process(comm);
      std::vector<double>    distances(points.size() * n);
      for (std::size_t k = 0; k < points.size(); ++k)
        {
          const auto nearest = locator->nearest_box_distances(points[k]);
          std::copy(nearest.begin(), nearest.end(), distances.begin() + k * n);
        }
      // An all-reduce that keeps the n smallest of two ascending lists of n: O(points) per process.
      MPI_Datatype list;
      MPI_Type_contiguous(n, MPI_DOUBLE, &list);
      MPI_Type_commit(&list);
      MPI_Op keep_smallest;
      MPI_Op_create(
        [](void *in, void *inout, int *count, MPI_Datatype *) {
          auto *a = static_cast<double *>(in), *b = static_cast<double *>(inout);
          std::array<double, 2 * n> both;
          for (int k = 0; k < *count; ++k, a += n, b += n)
            {
              std::merge(a, a + n, b, b + n, both.begin());
              std::copy(both.begin(), both.begin() + n, b);
            }
        },
        /*commute*/ 1, &keep_smallest);
      int ierr = MPI_Allreduce(MPI_IN_PLACE, distances.data(), points.size(), list, keep_smallest, comm);
      MPI_Op_free(&keep_smallest);
      MPI_Type_free(&list);
      AssertThrowMPI(ierr);
      std::vector<space_parts::LocatedPoint>  located;
      std::vector<Claim>                      claims;
      for (std::size_t k = 0; k < points.size(); ++k)
        {
          located.push_back(locator->locate(points[k], distances[k * n + n - 1]));
          claims.push_back({std::max(-located.back().distance_outside, std::numeric_limits<double>::lowest()), rank});
        }
      ierr = MPI_Allreduce(MPI_IN_PLACE, claims.data(), claims.size(), MPI_DOUBLE_INT, MPI_MAXLOC, comm);
      AssertThrowMPI(ierr);
      std::vector<space_parts::EvaluationPoint> evaluated(points.size());
      for (std::size_t k = 0; k < points.size(); ++k)
        {
          if (max_outside)
            *max_outside = std::max(*max_outside, -claims[k].closeness);
          if (claims[k].rank == rank)
            evaluated[k] = {DoFHandler<3>::active_cell_iterator(&triangulation, located[k].cell->level(),
                                                                located[k].cell->index(), &dof_handler),
                            located[k].unit};
        }
      return evaluated;
    }

    DistributedVector DistributedSpace::ghosted(const DistributedVector &owned) const
    {
      DistributedVector u = ghosted_layout;
      u = owned;
      return u;
    }

    // Ghosted, the constrained entries filled in (the DoFs of a node, which the constraints couple,
    // are owned by one process).
    DistributedVector DistributedSpace::output_field(const DistributedVector &u) const
    {
      DistributedVector owned = owned_layout;
      owned = u;
      if (coupled_constraints)
        constraints.distribute(owned);
      return ghosted(owned);
    }

    // K u = f in place for every field, with A = K - shift M (MUMPS's factor or the AMG): one block
    // solve without a shift, refined against K with one (space_parts::refine_static_solve, as the
    // serial solve_static), u += A^-1 (f - K u) on the whole block per step.
    void DistributedSpace::solve_static(std::vector<DistributedVector> &fields)
    {
      if (fields.empty())
        return;
      if (shift == 0.)
        {
          apply_inverse(fields);
          return;
        }
      const std::vector<DistributedVector> loads = fields;
      std::vector<DistributedVector>       corrections = fields;
      for (auto &u : fields)
        u = 0.;
      DistributedVector  K_u = owned_layout;
      const unsigned int steps = space_parts::refine_static_solve(
        [&] {
          apply_inverse(corrections);
          double worst = 0.;
          for (std::size_t c = 0; c < fields.size(); ++c)
            {
              fields[c] += corrections[c];
              stiffness_matrix.vmult(K_u, fields[c]);
              corrections[c] = loads[c];
              corrections[c] -= K_u; // the residual, solved for at the next step
              const double load_norm = loads[c].l2_norm();
              worst = std::max(worst, load_norm > 0. ? corrections[c].l2_norm() / load_norm : 0.);
            }
          return worst;
        },
        task.name, scene.modes.shift);
      result.static_solve_iterations = std::max(result.static_solve_iterations, steps);
    }

    void DistributedSpace::add_patch_loads(Block &X, const unsigned int first_column, const unsigned int vertex) const
    {
      X.columns.resize(std::max<std::size_t>(X.columns.size(), first_column + 3));
      for (unsigned int c = 0; c < 3; ++c)
        {
          std::array<double, 3> unit{};
          unit[c]                      = 1.;
          X.columns[first_column + c] = patch_load(vertex, unit);
        }
    }

    void DistributedSpace::add_combined_patch_loads(Block &X, const std::vector<const space_parts::DofWeights *> &rows,
                                                    const double *weights, const unsigned int count) const
    {
      X.columns.resize(std::max<std::size_t>(X.columns.size(), count));
      for (unsigned int j = 0; j < count; ++j)
        {
          DistributedVector load;
          load = writable_layout; // writable ghost entries, as in patch_load
          surface.add_rows(rows, weights + j * rows.size(), load);
          load.compress(VectorOperation::add);
          X.columns[j] = load;
        }
    }

    // The block's solutions, made readable at the owned cells' DoFs (block_column reads them so).
    void DistributedSpace::solve_static(Block &X)
    {
      solve_static(X.columns);
      for (auto &column : X.columns)
        {
          DistributedVector ghosted_column = ghosted(column);
          column.swap(ghosted_column);
        }
    }

    DistributedVector DistributedSpace::patch_load(const unsigned int vertex, const std::array<double, 3> &factor) const
    {
      // Writable ghost entries: a patch's cells may hold DoFs another process owns.
      DistributedVector load;
      load = writable_layout; // the assignment keeps the writable ghost part, the copy constructor would not
      surface.add_patch_load(vertex, factor, load);
      load.compress(VectorOperation::add);
      return load;
    }

    void DistributedSpace::sum_over_processes(std::vector<double> &values) const
    {
      const std::vector<double> local = values;
      Utilities::MPI::sum(local, comm, values);
    }


    // The process that evaluates a display vertex (evaluation_points) interpolates the modes there,
    // the others add zero: modes at this process's rows of the mesh vertices, for the parallel HDF5 file.
    void DistributedSpace::fill_modes_at_vertices()
    {
      const unsigned int r      = modes.size();
      const std::size_t  n_rows = owned_vertex_dofs.size();
      result.modes_at_vertices.resize(std::size_t(r) * n_rows * 3);
      for (unsigned int i = 0; i < r; ++i)
        {
          const DistributedVector mode = coupled_constraints ? output_field(modes[i]) : modes[i];
          for (std::size_t k = 0; k < n_rows; ++k)
            for (unsigned int c = 0; c < 3; ++c)
              result.modes_at_vertices[(std::size_t(i) * n_rows + k) * 3 + c] = mode[owned_vertex_dofs[k][c]];
        }
    }

    // The displacement component of the DoFs of this process's cells.
    std::map<types::global_dof_index, unsigned int> DistributedSpace::dof_components() const
    {
      std::map<types::global_dof_index, unsigned int> component;
      std::vector<types::global_dof_index>            dofs(fe.n_dofs_per_cell());
      for (const auto &cell : owned_cells)
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            component[dofs[i]] = fe.system_to_component_index(i).first;
        }
      return component;
    }

    // The rigid-body motions about 'centre' at this process's DoFs.
    std::array<DistributedVector, 6> DistributedSpace::rigid_body_motions(const Point<3> &centre) const
    {
      std::map<types::global_dof_index, Point<3>> support;
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      const auto component = dof_components();
      std::array<DistributedVector, 6> motions;
      for (unsigned int k = 0; k < 6; ++k)
        {
          motions[k] = owned_layout;
          for (const auto i : owned_dofs)
            motions[k][i] = rigid_body_motion(k, support.at(i) - centre)[component.at(i)];
          motions[k].compress(VectorOperation::insert);
        }
      return motions;
    }

  } // namespace

  ModalSpaceResult compute_modal_space_distributed(const SceneParameters &scene,
                                                   const ContactSurface  &display,
                                                   const SpaceTask       &task,
                                                   const std::string     &vtu_file,
                                                   TimerOutput           &timer,
                                                   const bool             verbose,
                                                   const MPI_Comm         comm)
  {
    DistributedSpace space(scene, display, task, vtu_file, timer, verbose, comm);
    return std::get<ModalSpaceResult>(space.run()); // the distributed backend hands no space over
  }
} // namespace modal_haptics
