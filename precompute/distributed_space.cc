#include "distributed_space.h"

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
#include <deal.II/lac/trilinos_solver.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_sparsity_pattern.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/numerics/data_out.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <iostream>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  namespace
  {
    constexpr double two_pi = 2. * M_PI;
    using DistributedVector = TrilinosWrappers::MPI::Vector;

    // The MUMPS factorization of K - sigma M: PArpackSolver's shift-invert operator (a const vmult)
    // and the solver of the static right-hand sides. Amesos_Mumps through deal.II is MUMPS's
    // unsymmetric LU (deal.II does not pass Amesos the symmetric option); it factorizes once.
    class MumpsInverse
    {
    public:
      MumpsInverse(const TrilinosWrappers::SparseMatrix &A, FactorizationStatistics &stats)
        : solver(control, TrilinosWrappers::SolverDirect::AdditionalData(false, "Amesos_Mumps"))
        , stats(stats)
      {
        stats.method = "mumps-lu (Trilinos Amesos_Mumps, distributed)";
        Timer timer;
        solver.initialize(A);
        stats.factorize_seconds = timer.wall_time();
      }

      void vmult(DistributedVector &dst, const DistributedVector &src) const
      {
        Timer timer;
        solver.solve(dst, src);
        stats.solve_seconds += timer.wall_time();
        ++stats.n_solved_vectors;
      }

    private:
      mutable SolverControl                  control;
      mutable TrilinosWrappers::SolverDirect solver;
      FactorizationStatistics               &stats;
    };

    class DistributedModalSpace : public space_parts::SpaceBase
    {
    public:
      DistributedModalSpace(const SceneParameters &scene, const DisplaySurface &display, const SpaceTask &task,
                            TimerOutput &timer, bool verbose, MPI_Comm comm);

    private:
      void assemble() override
      {
        read_and_partition_mesh();
        setup_system();
        assemble_system();
      }
      void solve_eigenproblem() override;
      void interpolate() override
      {
        interpolate_on_display_surface();
        compute_participation_factors();
      }
      void compute_static_correction() override;
      void validate() override;
      void output_results() const override;

      void read_and_partition_mesh();
      void setup_system();
      void assemble_system();
      void interpolate_on_display_surface();
      void compute_participation_factors();
      void validate_two_contacts();

      // Collective: every point is evaluated by one process, the one whose own cells hold it best (the
      // serial locator's rule, space_parts::PointLocator, ties to the lowest rank); the others get an
      // invalid cell. 'max_outside', if given, is the farthest a point lies outside the mesh.
      std::vector<space_parts::EvaluationPoint> evaluation_points(const std::vector<meshing::Point3> &points,
                                                                  double *max_outside = nullptr) const;
      // sum_d factor_d W_v e_d as a distributed vector; each process adds its cells' part.
      DistributedVector patch_load(unsigned int vertex, const std::array<double, 3> &factor) const;
      DistributedVector ghosted(const DistributedVector &owned) const;
      DistributedVector solve(const DistributedVector &rhs) const;
      // This process's part of W_v^T u (u ghosted); the sum over processes is the patch average.
      std::array<double, 3> local_patch_average(unsigned int vertex, const DistributedVector &u) const;
      // Appends this process's part of u at the display vertices (3 nv, component-fastest) to 'out'.
      void append_local_display_values(const DistributedVector &u, std::vector<double> &out) const;
      void sum_over_processes(std::vector<double> &values) const;

      const MPI_Comm comm;

      // Every process reads the whole mesh to partition it, then keeps only its share: the whole mesh
      // is gone before the matrices exist (docs/cluster.md).
      parallel::fullydistributed::Triangulation<3> triangulation;
      std::vector<unsigned int>                    whole_mesh_vertex;  // by local vertex index, of own and ghost cells
      std::vector<std::array<types::global_dof_index, 3>> owned_vertex_dofs; // of result.owned_rows->vertices
      DoFHandler<3>                                dof_handler;
      IndexSet                                     owned_dofs, relevant_dofs;
      AffineConstraints<double>                    constraints;
      TrilinosWrappers::SparseMatrix               stiffness_matrix, mass_matrix, shifted_matrix;
      std::unique_ptr<MumpsInverse>                inverse;
      std::vector<DoFHandler<3>::active_cell_iterator> owned_cells;
      std::unique_ptr<space_parts::PointLocator>   locator; // in the owned cells
      std::vector<std::pair<unsigned int, space_parts::DofWeights>> display_rows; // (3v + c, weights), owned cells
      std::map<unsigned int, space_parts::PatchLoad> patch_loads;               // this process's part
      std::vector<DistributedVector>               modes, ghosted_modes;        // kept, M-orthonormal
      std::vector<DistributedVector>               validation_fields;           // full - modal, ghosted
    };

    DistributedModalSpace::DistributedModalSpace(const SceneParameters &scene, const DisplaySurface &display,
                                                 const SpaceTask &task, TimerOutput &timer, const bool verbose,
                                                 const MPI_Comm comm)
      : SpaceBase(scene, display, task, timer, verbose)
      , comm(comm)
      , triangulation(comm)
    {}

    // The FACTS recipe: every process reads the serial mesh, partitions it (METIS, deterministic) and
    // builds its part of the fully distributed mesh; material and boundary ids carry over. A coarse
    // cell keeps its whole-mesh index as its id: what this process needs of the whole mesh (the
    // whole-mesh numbers of its vertices, its tets for the HDF5 file) is taken from it here, and the
    // whole mesh is freed.
    void DistributedModalSpace::read_and_partition_mesh()
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

    void DistributedModalSpace::setup_system()
    {
      dof_handler.reinit(triangulation);
      dof_handler.distribute_dofs(fe);
      result.n_dofs = dof_handler.n_dofs();
      owned_dofs    = dof_handler.locally_owned_dofs();
      DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);

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

      AssertThrow(!scene.free_floating(),
                  ExcMessage("A free-floating part (no 'Geometry/Clamp groups') runs on the serial path only: "
                             "run modal-precompute without mpirun or --distributed."));
      constraints.clear();
      constraints.reinit(relevant_dofs);
      space_parts::add_clamp_constraints(scene, task, mapping, dof_handler, constraints, comm);
      constraints.close();
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
          std::to_string(Utilities::MPI::n_mpi_processes(comm)) + " processes");
    }

    void DistributedModalSpace::assemble_system()
    {
      const auto assembler = space_parts::assemble_elasticity(scene, mapping, fe, quadrature, owned_cells, constraints,
                                                              stiffness_matrix, mass_matrix);
      stiffness_matrix.compress(VectorOperation::add);
      mass_matrix.compress(VectorOperation::add);

      // As in the serial space: M_ii = 0 on constrained rows moves their spurious eigenvalues
      // K_ii / M_ii to infinity.
      for (const auto i : owned_dofs)
        if (constraints.is_constrained(i))
          mass_matrix.set(i, i, 0.);
      mass_matrix.compress(VectorOperation::insert);
      result.n_spurious_rows = result.n_clamped_dofs;
      assembler.set_mass_properties(result, [&](const double x) { return Utilities::MPI::sum(x, comm); });
    }

    // PARPACK in mode 3 (shift-invert, M inner product) over the MUMPS factorization. The start
    // vector is a fixed function of the DoF positions, not of their numbering or partition, so that
    // runs on different process counts build nearly the same Krylov space.
    void DistributedModalSpace::solve_eigenproblem()
    {
      const double shift = std::copysign(std::pow(two_pi * scene.modes.shift, 2), scene.modes.shift);
      log(std::string("Modes/Eigensolver (") + (scene.modes.block_krylov ? "block-krylov" : "arpack") +
          ") and Modes/Operator (" + (scene.modes.eigen_operator == EigenOperator::cholmod ? "cholmod" : "umfpack") +
          ") choose the serial solvers; the distributed path uses PARPACK over MUMPS");
      log("factorizing K with MUMPS (Trilinos Amesos_Mumps)");
      if (shift != 0.)
        {
          shifted_matrix.copy_from(stiffness_matrix);
          shifted_matrix.add(-shift, mass_matrix);
        }
      inverse = std::make_unique<MumpsInverse>(shift != 0. ? shifted_matrix : stiffness_matrix, result.factorization);

      const int n   = result.n_dofs;
      const int nev = scene.modes.maximum_count;
      AssertThrow(nev >= 1 && nev < n - 1,
                  ExcMessage("Cannot compute " + std::to_string(nev) + " modes of a system with " + std::to_string(n) +
                             " unknowns: lower 'Modes/Maximum number of modes' or refine the mesh."));
      const unsigned int ncv = std::min(n - 1, std::max(2 * nev + 10, 20)); // as the serial ARPACK call

      std::map<types::global_dof_index, Point<3>> support;
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      DistributedVector start(owned_dofs, comm);
      for (const auto i : owned_dofs)
        {
          const Point<3> &x = support.at(i);
          start[i]          = constraints.is_constrained(i) ? 0. : 1. + 0.5 * std::sin(1e3 * (x[0] + 2. * x[1] + 3. * x[2]) + i % 3);
        }
      start.compress(VectorOperation::insert);

      SolverControl control(10000, scene.modes.tolerance, false, false);
      PArpackSolver<DistributedVector> solver(
        control, comm,
        PArpackSolver<DistributedVector>::AdditionalData(ncv, PArpackSolver<DistributedVector>::largest_magnitude,
                                                         /*symmetric*/ true, /*mode*/ 3));
      solver.reinit(owned_dofs);
      solver.set_shift(shift);
      solver.set_initial_vector(start);
      std::vector<std::complex<double>> lambda(nev);
      std::vector<DistributedVector>    vectors(nev, DistributedVector(owned_dofs, comm));
      Timer                             arpack_timer;
      solver.solve(stiffness_matrix, mass_matrix, *inverse, lambda, vectors, nev);
      result.arpack_seconds          = arpack_timer.wall_time();
      result.n_operator_applications = result.factorization.n_solved_vectors;
      result.eigensolver_method      = "PARPACK pdsaupd mode 3 (shift-invert), distributed";

      // PARPACK does not promise an order: sort ascending.
      std::vector<unsigned int> order(nev);
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](unsigned a, unsigned b) { return lambda[a].real() < lambda[b].real(); });
      std::vector<double>            eigenvalues;
      std::vector<DistributedVector> eigenvectors;
      for (const unsigned int i : order)
        {
          eigenvalues.push_back(lambda[i].real());
          // Normalize again so that round-off does not accumulate.
          vectors[i] /= std::sqrt(mass_matrix.matrix_norm_square(vectors[i]));
          eigenvectors.push_back(std::move(vectors[i]));
        }
      // MUMPS's LU factorizes an indefinite K - shift M too, where the serial Cholesky refuses it: a
      // mode below the shift says that the shift lies above the first eigenfrequency.
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
      std::ostringstream line;
      line << eigenvalues.size() << " modes in " << result.n_operator_applications << " solves, "
           << result.arpack_seconds << " s; f1 = " << result.computed_frequencies_hz.front()
           << " Hz; max |Phi^T M Phi - I| = " << result.self_check.orthonormality_error
           << ", max ||K phi - lambda M phi|| / ||lambda M phi|| = " << result.self_check.max_relative_residual
           << "; kept " << modes.size();
      log(line.str());
    }

    std::vector<space_parts::EvaluationPoint>
    DistributedModalSpace::evaluation_points(const std::vector<meshing::Point3> &points, double *max_outside) const
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

    DistributedVector DistributedModalSpace::ghosted(const DistributedVector &owned) const
    {
      DistributedVector u(owned_dofs, relevant_dofs, comm);
      u = owned;
      return u;
    }

    DistributedVector DistributedModalSpace::solve(const DistributedVector &rhs) const
    {
      DistributedVector x(owned_dofs, comm);
      inverse->vmult(x, rhs);
      return x;
    }

    DistributedVector DistributedModalSpace::patch_load(const unsigned int vertex, const std::array<double, 3> &factor) const
    {
      // Writable ghost entries: a patch's cells may hold DoFs another process owns.
      DistributedVector load;
      load.reinit(owned_dofs, relevant_dofs, comm, /*vector_writable*/ true);
      for (unsigned int d = 0; d < 3; ++d)
        if (factor[d] != 0.)
          for (const auto &[dof, w] : patch_loads.at(vertex)[d])
            load[dof] += factor[d] * w;
      load.compress(VectorOperation::add);
      return load;
    }

    std::array<double, 3> DistributedModalSpace::local_patch_average(const unsigned int vertex,
                                                                     const DistributedVector &u) const
    {
      std::array<double, 3> average{};
      for (unsigned int c = 0; c < 3; ++c)
        for (const auto &[dof, w] : patch_loads.at(vertex)[c])
          average[c] += w * u[dof];
      return average;
    }

    void DistributedModalSpace::append_local_display_values(const DistributedVector &u, std::vector<double> &out) const
    {
      const std::size_t first = out.size();
      out.resize(first + 3 * std::size_t(display.n_vertices()), 0.);
      for (const auto &[row, weights] : display_rows)
        for (const auto &[dof, w] : weights)
          out[first + row] += w * u[dof];
    }

    void DistributedModalSpace::sum_over_processes(std::vector<double> &values) const
    {
      const std::vector<double> local = values;
      Utilities::MPI::sum(local, comm, values);
    }

    // The process that evaluates a display vertex (evaluation_points) interpolates the modes there,
    // the others add zero.
    void DistributedModalSpace::interpolate_on_display_surface()
    {
      double     max_outside = 0.;
      const auto evaluated   = evaluation_points(display.vertices, &max_outside);
      for (unsigned int v = 0; v < display.n_vertices(); ++v)
        if (evaluated[v].cell.state() == IteratorState::valid)
          for (unsigned int c = 0; c < 3; ++c)
            {
              display_rows.emplace_back(3 * v + c, space_parts::DofWeights());
              space_parts::add_shape_values(evaluated[v].cell, evaluated[v].unit, c, 1., display_rows.back().second);
            }

      const unsigned int  r  = modes.size();
      const unsigned int  nv = display.n_vertices();
      std::vector<double> by_mode; // r blocks of 3 nv
      for (const auto &mode : ghosted_modes)
        append_local_display_values(mode, by_mode);
      sum_over_processes(by_mode);
      result.display_modes.resize(std::size_t(3) * nv * r);
      for (unsigned int row = 0; row < 3 * nv; ++row)
        for (unsigned int i = 0; i < r; ++i)
          result.display_modes[std::size_t(row) * r + i] = by_mode[std::size_t(i) * 3 * nv + row];

      // Modes at this process's rows of the mesh vertices, for the parallel HDF5 file.
      const std::size_t n_rows = owned_vertex_dofs.size();
      result.modes_at_vertices.resize(std::size_t(r) * n_rows * 3);
      for (unsigned int i = 0; i < r; ++i)
        for (std::size_t k = 0; k < n_rows; ++k)
          for (unsigned int c = 0; c < 3; ++c)
            result.modes_at_vertices[(std::size_t(i) * n_rows + k) * 3 + c] = modes[i][owned_vertex_dofs[k][c]];
      std::ostringstream line;
      line << "display surface: " << nv << " vertices located, farthest outside the mesh by " << max_outside
           << " (barycentric)";
      log(line.str());
    }

    // Gamma = Phi^T M R with R the rigid translations and rotations about the centre of mass.
    void DistributedModalSpace::compute_participation_factors()
    {
      std::map<types::global_dof_index, Point<3>> support;
      DoFTools::map_dofs_to_support_points(mapping, dof_handler, support);
      std::map<types::global_dof_index, unsigned int> component;
      std::vector<types::global_dof_index>            dofs(fe.n_dofs_per_cell());
      for (const auto &cell : owned_cells)
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            component[dofs[i]] = fe.system_to_component_index(i).first;
        }
      const Point<3> c(result.centre_of_mass[0], result.centre_of_mass[1], result.centre_of_mass[2]);
      const unsigned int r = modes.size();
      result.participation.assign(std::size_t(r) * 6, 0.);
      DistributedVector rigid(owned_dofs, comm), M_rigid(owned_dofs, comm);
      for (unsigned int k = 0; k < 6; ++k)
        {
          for (const auto i : owned_dofs)
            {
              const Tensor<1, 3> x = support.at(i) - c;
              Tensor<1, 3>       u;
              if (k < 3)
                u[k] = 1.;
              else
                {
                  Tensor<1, 3> axis;
                  axis[k - 3] = 1.;
                  u           = cross_product_3d(axis, x);
                }
              rigid[i] = u[component.at(i)];
            }
          rigid.compress(VectorOperation::insert);
          mass_matrix.vmult(M_rigid, rigid);
          for (unsigned int i = 0; i < r; ++i)
            result.participation[std::size_t(i) * 6 + k] = modes[i] * M_rigid;
        }
    }

    // C_v = W_v^T K^-1 W_v - B_v Lambda^-1 B_v^T with one MUMPS solve per load and direction; the
    // patch averages every solve needs are summed over the processes once per load.
    void DistributedModalSpace::compute_static_correction()
    {
      const unsigned int r     = modes.size();
      const auto         loads = space_parts::plan_static_correction(scene, task, result);
      const unsigned int nc    = result.candidates.size();
      Timer              wall;
      for (const unsigned int v : loads)
        patch_loads[v] = space_parts::make_patch_load(display, v, [&](const std::vector<meshing::Point3> &points) {
          return evaluation_points(points);
        });

      for (unsigned int a = 0; a < nc; ++a)
        for (unsigned int i = 0; i < r; ++i)
          {
            const auto b = local_patch_average(result.candidates[a], ghosted_modes[i]);
            for (unsigned int c = 0; c < 3; ++c)
              result.candidate_modes[(3 * std::size_t(a) + c) * r + i] = b[c];
          }
      sum_over_processes(result.candidate_modes);

      // Targets of one load's averages: the load itself, then every candidate (cross compliance).
      const bool  store_cross = !result.cross_compliance.empty();
      const auto  n_targets   = 1 + (store_cross ? nc : 0);
      std::vector<double> averages(3 * n_targets * 3);
      for (unsigned int load = 0; load < loads.size(); ++load)
        {
          std::fill(averages.begin(), averages.end(), 0.);
          for (unsigned int d = 0; d < 3; ++d)
            {
              std::array<double, 3> unit{};
              unit[d]                     = 1.;
              const DistributedVector x   = ghosted(solve(patch_load(loads[load], unit)));
              for (unsigned int t = 0; t < n_targets; ++t)
                {
                  const auto u = local_patch_average(t == 0 ? loads[load] : result.candidates[t - 1], x);
                  std::copy(u.begin(), u.end(), &averages[(d * n_targets + t) * 3]);
                }
            }
          sum_over_processes(averages);
          space_parts::record_static_response(
            result, task, load, loads[load], [&](const unsigned int vertex, const unsigned int d) {
              const std::size_t t =
                vertex == loads[load] ?
                  0 :
                  1 + (std::lower_bound(result.candidates.begin(), result.candidates.end(), vertex) - result.candidates.begin());
              std::array<double, 3> u;
              std::copy(&averages[(d * n_targets + t) * 3], &averages[(d * n_targets + t) * 3] + 3, u.begin());
              return u;
            });
        }
      result.correction_seconds_per_candidate = loads.empty() ? 0. : wall.wall_time() / loads.size();
      log(space_parts::static_correction_summary(result, loads.size()));
    }

    void DistributedModalSpace::validate()
    {
      const unsigned int r  = modes.size();
      const std::size_t  nv = display.n_vertices();
      DistributedVector  residual(owned_dofs, comm);
      for (const unsigned int vertex : task.validation_vertices)
        for (unsigned int direction = 0; direction < 3; ++direction)
          {
            ValidationCase vc;
            vc.vertex    = vertex;
            vc.direction = direction;
            std::array<double, 3> unit{};
            unit[direction]           = 1.;
            const DistributedVector f = patch_load(vertex, unit);
            const DistributedVector u = solve(f);
            stiffness_matrix.vmult(residual, u);
            residual -= f;
            vc.solve_relative_residual = residual.l2_norm() / f.l2_norm();

            DistributedVector   u_modal(owned_dofs, comm);
            std::vector<double> modal_coefficients(r);
            for (unsigned int i = 0; i < r; ++i)
              {
                modal_coefficients[i] = (modes[i] * f) / result.eigenvalues[i];
                u_modal.add(modal_coefficients[i], modes[i]);
              }
            DistributedVector difference = u;
            difference -= u_modal;
            vc.energy_rel_error_modal =
              std::sqrt(stiffness_matrix.matrix_norm_square(difference) / stiffness_matrix.matrix_norm_square(u));

            // One sum over the processes: both patch averages, then both display fields.
            const DistributedVector u_ghosted = ghosted(u), u_modal_ghosted = ghosted(u_modal);
            std::vector<double>     values(6);
            const auto              full = local_patch_average(vertex, u_ghosted), modal = local_patch_average(vertex, u_modal_ghosted);
            std::copy(full.begin(), full.end(), values.begin());
            std::copy(modal.begin(), modal.end(), values.begin() + 3);
            append_local_display_values(u_ghosted, values);
            append_local_display_values(u_modal_ghosted, values);
            sum_over_processes(values);
            std::array<double, 3> uc_full, uc_modal;
            std::copy(values.begin(), values.begin() + 3, uc_full.begin());
            std::copy(values.begin() + 3, values.begin() + 6, uc_modal.begin());
            space_parts::set_validation_errors(vc, result, display, scene.contact.correction_field_tolerance, uc_full,
                                               uc_modal, std::vector<double>(values.begin() + 6, values.begin() + 6 + 3 * nv),
                                               std::vector<double>(values.begin() + 6 + 3 * nv, values.end()), modal_coefficients);
            validation_fields.push_back(ghosted(difference));
            result.validation.push_back(vc);
          }
      validate_two_contacts();
      log(space_parts::validation_summary(result));
    }

    void DistributedModalSpace::validate_two_contacts()
    {
      if (task.validation_vertices.size() < 2 || result.cross_compliance.empty())
        return;
      const std::array<unsigned int, 2> vertices = {task.validation_vertices.front(), task.validation_vertices.back()};
      DistributedVector                 f(owned_dofs, comm);
      for (unsigned int h = 0; h < 2; ++h)
        f += patch_load(vertices[h], space_parts::two_contact_forces[h]);
      const DistributedVector u = ghosted(solve(f));
      std::vector<double>     values;
      for (const unsigned int v : vertices)
        {
          const auto average = local_patch_average(v, u);
          values.insert(values.end(), average.begin(), average.end());
        }
      sum_over_processes(values);
      result.two_contact_rel_error_corrected =
        space_parts::two_contact_error(result, vertices, {{{{values[0], values[1], values[2]}}, {{values[3], values[4], values[5]}}}});
    }

    // One .vtu written by all processes together (MPI I/O), the same file name as the serial run.
    void DistributedModalSpace::output_results() const
    {
      if (task.vtu_file.empty())
        return;
      DataOut<3> data_out;
      data_out.attach_dof_handler(dof_handler);
      const std::vector<DataComponentInterpretation::DataComponentInterpretation> vector_field(
        3, DataComponentInterpretation::component_is_part_of_vector);
      const unsigned int n_vtu = std::min<unsigned int>(scene.output.vtu_modes, ghosted_modes.size());
      for (unsigned int i = 0; i < n_vtu; ++i)
        data_out.add_data_vector(ghosted_modes[i],
                                 std::vector<std::string>(3, space_parts::mode_field_name(i, result.frequencies_hz[i])),
                                 DataOut<3>::type_dof_data, vector_field);
      for (unsigned int k = 0; k < validation_fields.size(); ++k)
        data_out.add_data_vector(validation_fields[k],
                                 std::vector<std::string>(3, space_parts::validation_field_name(result.validation[k])),
                                 DataOut<3>::type_dof_data, vector_field);
      data_out.build_patches(mapping, scene.element_degree);
      data_out.write_vtu_in_parallel(task.vtu_file, comm);
    }
  } // namespace

  ModalSpaceResult compute_modal_space_distributed(const SceneParameters &scene,
                                                   const DisplaySurface  &display,
                                                   const SpaceTask       &task,
                                                   TimerOutput           &timer,
                                                   const bool             verbose,
                                                   const MPI_Comm         comm)
  {
    DistributedModalSpace space(scene, display, task, timer, verbose, comm);
    return space.run();
  }
} // namespace modal_haptics
