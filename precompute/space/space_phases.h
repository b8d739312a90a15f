// The phases of a modal space after its eigensolve, written once against a small linear-algebra
// backend: display interpolation, participation factors, static correction, validation, the
// two-contact check, the validity map and the VTU output. The serial space (modal_space.cc: CHOLMOD or UMFPACK,
// deal.II vectors) and the distributed one (distributed_space.cc: Trilinos matrices, MUMPS,
// PARPACK) are the two backends, as ASPECT separates its assembly from its solver backends; both
// compute every quantity by the same code, so serial and distributed agree by construction.
//
// A backend provides (the distributed one holds only its own rows; "local" means this process's
// share, summed over the processes by sum_over_processes, an identity when serial):
//   Field, Block                      a DoF vector; a block of DoF vectors solved together
//   stiffness_matrix, mass_matrix     K and M (vmult, matrix_norm_square)
//   dof_handler                       the FE space's (a process's own cells marked as such)
//   const std::vector<Field> &kept_modes() const     M-orthonormal, ascending
//   ghosted(const Field &) const      readable at every DoF of the owned cells (a copy or a reference)
//   const std::vector<Field> &ghosted_kept_modes() const   ghosted(kept_modes()[i]) each, kept
//   Field zero_field() const
//   std::vector<EvaluationPoint> evaluation_points(points, double *max_outside) const  (collective)
//   Field patch_load(unsigned vertex, const std::array<double, 3> &factor) const   sum_d factor_d W_v e_d
//   nonlinear::SpaceView<Algebra> validity_space()   what the nonlinear solves read (large_deformation.h)
//   void relieve_load(Field &) const  inertia relief of a free part's load (identity when clamped)
//   Block new_block(unsigned n_columns) const
//   void add_patch_loads(Block &, unsigned first_column, unsigned vertex) const   W_v e_0..2
//   void add_combined_patch_loads(Block &, rows, const double *weights, unsigned count) const   column j += sum_row
//                                 weights[j m + row] W_row, m = rows.size() (surface.patch_rows)
//   void patch_row_averages(const Block &, rows, unsigned count, double *averages) const        W_row^T column j
//                                     sum_k W_{vertices[k]} (weights 3k .. 3k + 2) into one column
//   void solve_static(Block &)
//   unsigned columns_per_static_solve(unsigned wanted) const   at most wanted: fewer where a block
//                                     solve's work space would not fit the memory
//   void solve_static(std::vector<Field> &)   K^-1 in place (with a free part: the inertia-relief
//                                     answer), several fields together where that is cheaper
//   bool group_grams(groups, grams)   per ContactGroup, W^T K^-1 W_members of its vertices' patch loads
//                                     (3 columns per vertex), if the backend can without solving each
//   const auto &block_column(const Block &, unsigned column) const               ghosted
//   void sum_over_processes(std::vector<double> &) const
//   void condense(DofWeights &) const  weights on constrained DoFs moved to the DoFs they follow (C^T w)
//   Field output_field(const Field &) const   ghosted, the constrained entries filled in (for output)
//   std::array<Field, 6> rigid_body_motions(const dealii::Point<3> &centre) const
//   void fill_modes_at_vertices()     the kept modes at the result's rows of mesh vertices
//   void write_vtu(space_phases::VtuOutput &) const   after build_patches
//   SurfaceOperators surface;         filled by the phases below
//   std::vector<Field> validation_fields;   full - modal, one per validation case, as output_field gives
//
// Every field of the phases is a vector of the constrained system: zero on constrained DoFs. Loads
// and readings (display rows, patch loads) are condensed once, so they act on and read such fields
// as the full fields they stand for; only the output fills the constrained entries in.
#pragma once

#include "nonlinear/large_deformation.h"
#include "scene/linear_tet.h"
#include "space/far_field.h"
#include "space/modal_space.h"

#include <deal.II/base/parallel.h>
#include <deal.II/base/timer.h>
#include <deal.II/numerics/data_out.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>

namespace modal_haptics
{
  namespace space_phases
  {
    // The display surface seen from a space's DoFs: the interpolation rows (3v + c, weights) this
    // process evaluates, and the patch loads W_v of the loaded vertices (this process's part).
    struct SurfaceOperators
    {
      std::vector<std::pair<unsigned int, space_parts::DofWeights>> display_rows;
      std::map<unsigned int, space_parts::PatchLoad>                patch_loads;

      // This process's part of W_v^T u.
      template <typename VectorType>
      std::array<double, 3> local_patch_average(const unsigned int vertex, const VectorType &u) const
      {
        std::array<double, 3> average{};
        for (unsigned int c = 0; c < 3; ++c)
          for (const auto &[dof, w] : patch_loads.at(vertex)[c])
            average[c] += w * u[dof];
        return average;
      }

      // load += sum_d factor_d W_v e_d (this process's part).
      template <typename VectorType>
      void add_patch_load(const unsigned int vertex, const std::array<double, 3> &factor, VectorType &load) const
      {
        for (unsigned int d = 0; d < 3; ++d)
          if (factor[d] != 0.)
            for (const auto &[dof, w] : patch_loads.at(vertex)[d])
              load[dof] += factor[d] * w;
      }

      // The rows of W over 'vertices' (row 3 a + c: vertex a's patch load along c, this process's
      // part), each vertex looked up once: a block's many columns then read them without the map.
      std::vector<const space_parts::DofWeights *> patch_rows(const std::vector<unsigned int> &vertices) const
      {
        std::vector<const space_parts::DofWeights *> rows;
        rows.reserve(3 * vertices.size());
        for (const unsigned int v : vertices)
          for (const auto &direction : patch_loads.at(v))
            rows.push_back(&direction);
        return rows;
      }

      // load += sum_row weights[row] W_row.
      template <typename VectorType>
      static void add_rows(const std::vector<const space_parts::DofWeights *> &rows, const double *weights,
                           VectorType &load)
      {
        for (std::size_t row = 0; row < rows.size(); ++row)
          if (weights[row] != 0.)
            for (const auto &[dof, w] : *rows[row])
              load[dof] += weights[row] * w;
      }

      // averages[row] = W_row^T u (this process's part).
      template <typename VectorType>
      static void row_averages(const std::vector<const space_parts::DofWeights *> &rows, const VectorType &u,
                               double *averages)
      {
        for (std::size_t row = 0; row < rows.size(); ++row)
          {
            double sum = 0.;
            for (const auto &[dof, w] : *rows[row])
              sum += w * u[dof];
            averages[row] = sum;
          }
      }

      // The same for the columns j < count of a column-major block (n rows each), with weights and
      // averages column-major too (m = rows.size() per column): eight columns at a time through a
      // row-major copy, so that each weight of W meets the eight columns in one cache line (one
      // column at a time, the scattered reads and writes cost more than a block's solve). The
      // chunks of eight run on the threads (a far field's 64 columns left a core idle), each column
      // written by one thread in one order: the same numbers whichever thread takes it.
      static constexpr unsigned int chunk = 8;
      static void add_rows_to_columns(const std::vector<const space_parts::DofWeights *> &rows, const double *weights,
                                      const unsigned int count, double *block, const std::size_t n)
      {
        const std::size_t m = rows.size();
        for_chunks_of_columns(count, [&](const unsigned int first, const unsigned int width, std::vector<double> &loads) {
          loads.assign(n * chunk, 0.);
          for (std::size_t row = 0; row < m; ++row)
            {
              double of_row[chunk] = {};
              for (unsigned int j = 0; j < width; ++j)
                of_row[j] = weights[(first + j) * m + row];
              for (const auto &[dof, w] : *rows[row])
                for (unsigned int j = 0; j < chunk; ++j)
                  loads[dof * chunk + j] += w * of_row[j];
            }
          for (unsigned int j = 0; j < width; ++j)
            for (std::size_t dof = 0; dof < n; ++dof)
              block[(first + j) * n + dof] += loads[dof * chunk + j];
        });
      }
      static void row_averages_of_columns(const std::vector<const space_parts::DofWeights *> &rows,
                                          const double *block, const std::size_t n, const unsigned int count,
                                          double *averages)
      {
        const std::size_t m = rows.size();
        for_chunks_of_columns(count, [&](const unsigned int first, const unsigned int width, std::vector<double> &columns) {
          columns.assign(n * chunk, 0.);
          for (unsigned int j = 0; j < width; ++j)
            for (std::size_t dof = 0; dof < n; ++dof)
              columns[dof * chunk + j] = block[(first + j) * n + dof];
          for (std::size_t row = 0; row < m; ++row)
            {
              double sum[chunk] = {};
              for (const auto &[dof, w] : *rows[row])
                for (unsigned int j = 0; j < chunk; ++j)
                  sum[j] += w * columns[dof * chunk + j];
              for (unsigned int j = 0; j < width; ++j)
                averages[(first + j) * m + row] = sum[j];
            }
        });
      }
      // work(first, width, scratch) for each chunk of columns [first, first + width), on the threads;
      // scratch is the calling thread's own.
      template <typename Work>
      static void for_chunks_of_columns(const unsigned int count, const Work &work)
      {
        const unsigned int n_chunks = (count + chunk - 1) / chunk;
        dealii::parallel::apply_to_subranges(
          0u, n_chunks,
          [&](const unsigned int begin, const unsigned int end) {
            std::vector<double> scratch;
            for (unsigned int c = begin; c < end; ++c)
              work(c * chunk, std::min(chunk, count - c * chunk), scratch);
          },
          1);
      }

      // Appends this process's part of u at the display vertices (3 nv, component-fastest) to 'out'.
      template <typename VectorType>
      void append_local_display_values(const VectorType &u, const unsigned int n_display_vertices,
                                       std::vector<double> &out) const
      {
        const std::size_t first = out.size();
        out.resize(first + 3 * std::size_t(n_display_vertices), 0.);
        for (const auto &[row, weights] : display_rows)
          for (const auto &[dof, w] : weights)
            out[first + row] += w * u[dof];
      }
    };

    using space_parts::PhaseInputs;

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

    // The loads' responses from the Gram matrices of their groups (the backend's group_grams): in
    // group g, the response at the group's vertex q to the load of its member p in direction d is
    // column 3p + d, rows 3q .. 3q + 2.
    template <typename Backend>
    bool record_from_group_grams(Backend &b, const PhaseInputs &in, ModalSpaceResult &result,
                                 const space_parts::StaticCorrectionPlan &plan)
    {
      const auto                      &groups = plan.blocks.groups;
      std::vector<std::vector<double>> grams;
      if (!b.group_grams(groups, grams))
        return false;
      for (std::size_t g = 0; g < groups.size(); ++g)
        {
          const auto        &vertices = groups[g].vertices;
          const std::size_t  m        = 3 * vertices.size();
          std::map<unsigned int, unsigned int> position;
          for (unsigned int k = 0; k < vertices.size(); ++k)
            position[vertices[k]] = k;
          for (unsigned int p = 0; p < plan.blocks.groups[g].n_members; ++p)
            space_parts::record_static_response(
              result, in.task, plan, plan.load_of_vertex[vertices[p]],
              [&](const unsigned int target, const unsigned int d) -> std::optional<std::array<double, 3>> {
                const auto found = position.find(target);
                if (found == position.end()) // a member of an earlier group, whose halo held vertices[p]
                  return std::nullopt;
                const std::size_t     q = found->second;
                std::array<double, 3> u;
                for (unsigned int c = 0; c < 3; ++c)
                  u[c] = grams[g][(3 * p + d) * m + 3 * q + c];
                return u;
              });
        }
      return true;
    }

    // The loads' responses by solving K u = W_v e_d a block of loads at a time and reading each
    // column's patch averages at the load itself and at its neighbours (cross compliance); the
    // averages of a block are summed over the processes once.
    template <typename Backend>
    void record_from_block_solves(Backend &b, const PhaseInputs &in, ModalSpaceResult &result,
                                  const space_parts::StaticCorrectionPlan &plan, const dealii::Timer &timer)
    {
      const auto &loads = plan.loads;
      // 16 loads (48 columns) per block: one pass over a factor serves them all.
      const unsigned int  block = std::max(1u, b.columns_per_static_solve(3 * 16) / 3);
      std::vector<double> averages;
      double              last_progress = 0.; // [s] of timer
      for (unsigned int first = 0; first < loads.size(); first += block)
        {
          const unsigned int count = std::min<unsigned int>(block, loads.size() - first);
          auto               X     = b.new_block(3 * count);
          for (unsigned int k = 0; k < count; ++k)
            b.add_patch_loads(X, 3 * k, loads[first + k]);
          b.solve_static(X);

          // Per load k and direction d, the averages at its response vertices, 3 each, in one vector.
          std::vector<std::vector<unsigned int>> targets(count);
          std::vector<std::size_t>               start(count + 1, 0);
          for (unsigned int k = 0; k < count; ++k)
            {
              targets[k]   = space_parts::response_vertices(result, plan, first + k);
              start[k + 1] = start[k] + 9 * targets[k].size();
            }
          averages.assign(start[count], 0.);
          for (unsigned int k = 0; k < count; ++k)
            for (unsigned int d = 0; d < 3; ++d)
              for (unsigned int t = 0; t < targets[k].size(); ++t)
                {
                  const auto u = b.surface.local_patch_average(targets[k][t], b.block_column(X, 3 * k + d));
                  std::copy(u.begin(), u.end(), &averages[start[k] + 3 * (d * targets[k].size() + t)]);
                }
          b.sum_over_processes(averages);
          for (unsigned int k = 0; k < count; ++k)
            space_parts::record_static_response(
              result, in.task, plan, first + k,
              [&](const unsigned int vertex, const unsigned int d) -> std::optional<std::array<double, 3>> {
                const std::size_t t = std::find(targets[k].begin(), targets[k].end(), vertex) - targets[k].begin();
                std::array<double, 3> u;
                std::copy_n(&averages[start[k] + 3 * (d * targets[k].size() + t)], 3, u.begin());
                return u;
              });
          // A line every 30 s: a block takes milliseconds over a factor, minutes without one.
          if (in.verbose && timer.wall_time() > last_progress + 30.)
            {
              last_progress = timer.wall_time();
              in.log("static correction: " + std::to_string(first + count) + " / " + std::to_string(loads.size()) +
                     " loads, " + std::to_string(int(last_progress)) + " s");
            }
        }
    }

    // Residual flexibility (mode acceleration): C_v = W_v^T K^-1 W_v - B_v Lambda^-1 B_v^T at the
    // candidates, the cross terms between neighbouring candidates, and the full W_v^T K^-1 W_v of
    // every load (the felt-stiffness map). Where the backend gives the Gram matrices of groups of
    // loads (a Cholesky factor of K: forward solves on the loads' elimination-tree paths only) they
    // come from those; else the loads are solved in blocks. For a free part K^-1 is the inertia-relief flexibility and Lambda^-1 leaves out the
    // rigid-body modes (static_gain).
    template <typename Backend>
    void compute_static_correction(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const auto        &modes = b.kept_modes();
      const unsigned int r     = modes.size();
      dealii::Timer      timer;
      auto plan = space_parts::plan_static_correction(in.scene, in.task, in.display, result);
      build_patch_loads(b, in, plan.loads);
      const double loads_built = timer.wall_time();

      // B_v = W_v^T Phi with the same W_v as the solves: then B Lambda^-1 B^T + C is W^T K^-1 W.
      plan.load_modes.assign(3 * std::size_t(r) * plan.loads.size(), 0.);
      for (unsigned int k = 0; k < plan.loads.size(); ++k)
        for (unsigned int i = 0; i < r; ++i)
          {
            const auto average = b.surface.local_patch_average(plan.loads[k], b.ghosted_kept_modes()[i]);
            for (unsigned int c = 0; c < 3; ++c)
              plan.load_modes[(3 * std::size_t(k) + c) * r + i] = average[c];
          }
      b.sum_over_processes(plan.load_modes);
      for (unsigned int a = 0; a < result.candidates.size(); ++a)
        {
          const std::size_t k = plan.load_of_vertex[result.candidates[a]];
          std::copy_n(&plan.load_modes[3 * r * k], 3 * r, &result.candidate_modes[3 * r * std::size_t(a)]);
        }

      const double modal_rows = timer.wall_time();
      if (!record_from_group_grams(b, in, result, plan))
        record_from_block_solves(b, in, result, plan, timer);
      space_parts::complete_cross_blocks(result);
      result.correction_seconds_per_candidate = plan.loads.empty() ? 0. : timer.wall_time() / plan.loads.size();
      in.log(space_parts::static_correction_summary(result, plan.loads.size()) + " (patch loads " +
             std::to_string(loads_built) + " s, modal rows " + std::to_string(modal_rows - loads_built) + " s, solves " +
             std::to_string(timer.wall_time() - modal_rows) + " s)");
    }

    // R X for blocks of candidate loads: column j of X holds 3 nc weights (the load sum_a W_a x_a);
    // the answer, W^T (K^-1 - Phi Lambda^+ Phi^T) W X, is 3 nc x k column-major like X, the same on
    // every process. Blocks of columns share a pass over the factor.
    template <typename Backend>
    std::vector<double> apply_residual_compliance(Backend &b, const ModalSpaceResult &result, const std::vector<double> &X,
                                                  const unsigned int k)
    {
      const auto        &candidates = result.candidates;
      const std::size_t  n          = 3 * candidates.size();
      const unsigned int r          = result.eigenvalues.size();
      std::vector<double> Y(n * k, 0.);
      const unsigned int  per_solve = std::max(1u, b.columns_per_static_solve(k));
      const auto          rows      = b.surface.patch_rows(candidates);
      for (unsigned int first = 0; first < k; first += per_solve)
        {
          const unsigned int count = std::min(per_solve, k - first);
          auto               block = b.new_block(count);
          b.add_combined_patch_loads(block, rows, &X[first * n], count);
          b.solve_static(block);
          b.patch_row_averages(block, rows, count, &Y[first * n]);
        }
      b.sum_over_processes(Y);
      // The modal part, B Lambda^+ B^T X, with B the candidates' modal rows.
      const auto &B = result.candidate_modes;
      for (unsigned int j = 0; j < k; ++j)
        {
          std::vector<double> q(r, 0.);
          for (std::size_t row = 0; row < n; ++row)
            for (unsigned int i = 0; i < r; ++i)
              q[i] += B[row * r + i] * X[j * n + row];
          for (unsigned int i = 0; i < r; ++i)
            q[i] *= static_gain(result.eigenvalues[i]);
          for (std::size_t row = 0; row < n; ++row)
            for (unsigned int i = 0; i < r; ++i)
              Y[j * n + row] -= B[row * r + i] * q[i];
        }
      return Y;
    }

    // The residual coupling of candidates farther apart than the stored blocks reach, as the factor
    // Z of a randomized Nystrom approximation R ~ Z Z^T (far_field.h): R applied to 'Far field rank'
    // random loads, the answers orthonormalized, R applied once more (a power step: the local
    // response each patch has of its own, which R's random image mixes in, weighs less against the
    // coupling that reaches far). Its error is measured against R's exact columns at a few sampled
    // candidates and reported by distance.
    template <typename Backend>
    void compute_far_field(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const std::size_t nc = result.candidates.size(), n = 3 * nc;
      if (in.scene.contact.far_field_rank == 0 || result.cross_offsets.empty() || nc < 2)
        return;
      const unsigned int k = std::min<std::size_t>(in.scene.contact.far_field_rank, n);
      dealii::Timer      timer;
      const unsigned int seed = 20261127u + result.index;
      std::vector<double> Q   = apply_residual_compliance(b, result, far_field::gaussian_probes(n, k, seed), k);
      const unsigned int  kq  = far_field::orthonormalize_columns(Q, n, k);
      const std::vector<double> Y = apply_residual_compliance(b, result, Q, kq);
      result.far_compliance       = far_field::nystrom_factor(Q, Y, n, kq, result.far_rank);
      result.far_field_seconds    = timer.wall_time();

      const auto sampled = far_field::sample_candidates(nc, 8, seed);
      std::vector<double> units(n * 3 * sampled.size(), 0.);
      for (std::size_t t = 0; t < sampled.size(); ++t)
        for (unsigned int d = 0; d < 3; ++d)
          units[(3 * t + d) * n + 3 * sampled[t] + d] = 1.;
      const auto exact = apply_residual_compliance(b, result, units, 3 * sampled.size());
      const auto measured              = far_field::error_by_distance(result, in.display.vertices, sampled, exact);
      result.far_field_bands           = measured.bands;
      result.far_field_rms_error       = measured.rms_error;
      result.far_field_rms_modes_alone = measured.rms_modes_alone;
      result.far_field_sampled.clear();
      for (const unsigned int s : sampled)
        result.far_field_sampled.push_back(result.candidates[s]);
      in.log(space_parts::far_field_summary(result) + " (checked against " + std::to_string(3 * sampled.size()) +
             " exact solves in " + std::to_string(timer.wall_time() - result.far_field_seconds) + " s)");
      // Where the residual coupling is mostly each patch's own (a stiff, compact part), a rank-k
      // factor cannot hold it, and at single pairs its error can exceed the coupling itself: a factor
      // that does not remove at least half of what the modes alone leave out is not kept.
      if (!(measured.rms_error < 0.5 * measured.rms_modes_alone))
        {
          std::ostringstream why;
          why << "at the sampled pairs its error (rms " << measured.rms_error << " of the contacts' own compliance) "
              << "is not below half of what the modes alone leave out (" << measured.rms_modes_alone << ")";
          result.far_field_left_out = why.str();
          result.far_compliance.clear();
          result.far_rank = 0;
          in.log("far field not kept: " + result.far_field_left_out);
        }
    }

    // Two hands on one space: pairs of neighbouring candidates (space_parts::two_contact_pairs), the
    // nearest candidates of each pair of 'Exact pair points' and pairs farther apart pushed at once
    // (in z and y), a fresh full solve each against the kernel's formula with the cross compliance,
    // u_a = B_a Lambda^-1 (B_a^T F_a + B_b^T F_b) + C_aa F_a + C_ab F_b.
    template <typename Backend>
    void validate_two_contacts(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      auto       pairs = space_parts::two_contact_pairs(result, in.scene.contact.validation_pairs);
      const auto named = space_parts::named_contact_pairs(result, in.scene, in.display);
      const auto far   = space_parts::far_contact_pairs(result, in.scene.contact.validation_pairs);
      const std::size_t first_named = pairs.size(), first_far = first_named + named.size();
      pairs.insert(pairs.end(), named.begin(), named.end());
      pairs.insert(pairs.end(), far.begin(), far.end());
      if (pairs.empty())
        return;
      std::vector<typename Backend::Field> fields;
      for (const auto &vertices : pairs)
        {
          fields.push_back(b.zero_field());
          for (unsigned int h = 0; h < 2; ++h)
            fields.back() += b.patch_load(vertices[h], space_parts::two_contact_forces[h]);
        }
      b.solve_static(fields);
      std::vector<double> values;
      for (std::size_t k = 0; k < pairs.size(); ++k)
        {
          const auto &u = b.ghosted(fields[k]);
          for (const unsigned int v : pairs[k])
            {
              const auto average = b.surface.local_patch_average(v, u);
              values.insert(values.end(), average.begin(), average.end());
            }
        }
      b.sum_over_processes(values);
      result.two_contact_checks.clear();
      for (std::size_t k = 0; k < pairs.size(); ++k)
        {
          const double *u = &values[6 * k];
          TwoContactCheck check;
          check.vertices = pairs[k];
          const auto &x = in.display.vertices;
          check.distance = std::hypot(x[pairs[k][0]][0] - x[pairs[k][1]][0], x[pairs[k][0]][1] - x[pairs[k][1]][1],
                                      x[pairs[k][0]][2] - x[pairs[k][1]][2]);
          const std::array<std::array<double, 3>, 2> full = {{{{u[0], u[1], u[2]}}, {{u[3], u[4], u[5]}}}};
          check.named                   = k >= first_named && k < first_far;
          check.far                     = k >= first_far;
          check.rel_error_corrected     = space_parts::two_contact_error(result, pairs[k], full);
          check.rel_error_without_cross = space_parts::two_contact_error(result, pairs[k], full, false);
          if (!check.far) // the exact pairs' worst; the far ones are approximations, reported per pair
            result.two_contact_rel_error_corrected = std::max(result.two_contact_rel_error_corrected, check.rel_error_corrected);
          result.two_contact_checks.push_back(check);
        }
    }

    // Full static FE for sampled candidates and the three directions, against the modal answer and
    // the corrected one. The full solve is checked by its residual, so the comparison is with a true
    // solution of K u = f, not with the correction's own numbers.
    template <typename Backend>
    void validate(Backend &b, const PhaseInputs &in, ModalSpaceResult &result)
    {
      const auto        &modes = b.kept_modes();
      const unsigned int r     = modes.size();
      const std::size_t  nv    = in.display.n_vertices();
      auto               residual = b.zero_field();
      // Every case's load, then their full solutions, solved together (one pass over a factor).
      std::vector<typename Backend::Field> loads, solutions;
      for (const unsigned int vertex : in.task.validation_vertices)
        for (unsigned int direction = 0; direction < 3; ++direction)
          {
            std::array<double, 3> unit{};
            unit[direction] = 1.;
            loads.push_back(b.patch_load(vertex, unit));
            b.relieve_load(loads.back()); // a free part: the equilibrated share of the load
          }
      solutions = loads;
      b.solve_static(solutions);
      // K phi_i once: K u_modal is then their combination, and each case needs one product with K
      // (K u, for its residual and both energies) instead of three.
      std::vector<typename Backend::Field> K_modes(r, b.zero_field());
      for (unsigned int i = 0; i < r; ++i)
        b.stiffness_matrix.vmult(K_modes[i], modes[i]);
      auto K_u = b.zero_field();
      for (unsigned int k = 0; k < loads.size(); ++k)
        {
          const unsigned int vertex = in.task.validation_vertices[k / 3];
          ValidationCase     vc;
          vc.vertex    = vertex;
          vc.direction = k % 3;
          const auto &f = loads[k];
          const auto &u = solutions[k];
          b.stiffness_matrix.vmult(K_u, u);
          residual = K_u;
          residual -= f;
          vc.solve_relative_residual = residual.l2_norm() / f.l2_norm();

          auto                u_modal = b.zero_field();
          auto                K_difference = K_u; // K (u - u_modal)
          std::vector<double> modal_coefficients(r);
          for (unsigned int i = 0; i < r; ++i)
            {
              modal_coefficients[i] = (modes[i] * f) * static_gain(result.eigenvalues[i]);
              u_modal.add(modal_coefficients[i], modes[i]);
              K_difference.add(-modal_coefficients[i], K_modes[i]);
            }
          auto difference = u;
          difference -= u_modal;
          vc.energy_rel_error_modal = std::sqrt((difference * K_difference) / (u * K_u));

          // One sum over the processes: both patch averages, then both display fields.
          const auto         &u_ghosted = b.ghosted(u);
          const auto         &u_modal_ghosted = b.ghosted(u_modal);
          std::vector<double> values(6);
          const auto full  = b.surface.local_patch_average(vertex, u_ghosted);
          const auto modal = b.surface.local_patch_average(vertex, u_modal_ghosted);
          std::copy(full.begin(), full.end(), values.begin());
          std::copy(modal.begin(), modal.end(), values.begin() + 3);
          b.surface.append_local_display_values(u_ghosted, nv, values);
          b.surface.append_local_display_values(u_modal_ghosted, nv, values);
          b.sum_over_processes(values);
          std::array<double, 3> uc_full, uc_modal;
          std::copy(values.begin(), values.begin() + 3, uc_full.begin());
          std::copy(values.begin() + 3, values.begin() + 6, uc_modal.begin());
          space_parts::set_validation_errors(
            vc, result, in.display, in.scene.contact.correction_field_tolerance, uc_full, uc_modal,
            std::vector<double>(values.begin() + 6, values.begin() + 6 + 3 * nv),
            std::vector<double>(values.begin() + 6 + 3 * nv, values.end()), modal_coefficients);
          b.validation_fields.push_back(b.output_field(difference));
          result.validation.push_back(vc);
        }
      validate_two_contacts(b, in, result);
      in.log(space_parts::validation_summary(result));
    }

    // DataOut that hands its built patches over (the fields' values at the output's points, their
    // names and vector ranges, and its VTK flags): a VTU written from them needs neither the mesh nor
    // the vectors they came from, so it can be written on another thread while they are gone.
    class VtuOutput : public dealii::DataOut<3>
    {
    public:
      struct Patches
      {
        std::vector<dealii::DataOutBase::Patch<3, 3>> patches;
        std::vector<std::string>                      names;
        std::vector<std::tuple<unsigned int, unsigned int, std::string,
                               dealii::DataComponentInterpretation::DataComponentInterpretation>>
                                      vector_ranges;
        dealii::DataOutBase::VtkFlags flags;
        void write(std::ostream &out) const { dealii::DataOutBase::write_vtu(patches, names, vector_ranges, flags, out); }
      };

      void set_vtk_flags(const dealii::DataOutBase::VtkFlags &flags)
      {
        flags_for_vtu = flags;
        set_flags(flags);
      }

      // What build_patches(mapping, degree) makes of DoF fields of FESystem(FE_SimplexP(degree), 3) on
      // a linear-geometry tet mesh, read at the DoFs instead of evaluated through FEValues. A patch's
      // points are FE_SimplexP(degree)'s support points (deal.II's choice for simplex patches of
      // 'degree' subdivisions), where each shape function is 1 or 0, so a field's value at point j is
      // its DoF j (a -0 written as +0, which deal.II's sum over the shape functions makes of it).
      // Every simplex patch carries its points (deal.II stores them for any cell that is not a
      // hypercube), as the linear mapping computes them (point_in_linear_tet). 'fields' are those
      // added, in their order. The VTU phase of the default scene spent 1.2-1.4 s in build_patches;
      // precompute.vtu_patches compares both VTU files byte for byte.
      void build_patches_at_nodes(const dealii::DoFHandler<3>                    &dof_handler,
                                  const std::vector<const dealii::Vector<double> *> &fields)
      {
        const auto &fe = dof_handler.get_fe();
        AssertThrow(fe.n_base_elements() == 1 && fe.n_components() == 3 &&
                      fe.base_element(0).reference_cell() == dealii::ReferenceCells::Tetrahedron,
                    dealii::ExcMessage("build_patches_at_nodes: FESystem(FE_SimplexP, 3) on tets is expected"));
        const auto                                   &scalar = fe.base_element(0);
        const auto                                   &unit   = scalar.get_unit_support_points();
        const unsigned int                            rows   = 3 * fields.size();
        std::vector<dealii::types::global_dof_index> dofs(fe.n_dofs_per_cell());
        this->patches.clear();
        for (const auto &cell : dof_handler.active_cell_iterators())
          {
            if (!cell->is_locally_owned())
              continue;
            dealii::DataOutBase::Patch<3, 3> patch;
            patch.reference_cell = cell->reference_cell();
            patch.n_subdivisions = scalar.degree;
            patch.patch_index    = this->patches.size();
            for (unsigned int v = 0; v < 4; ++v)
              patch.vertices[v] = cell->vertex(v);
            patch.points_are_available = true;
            patch.data.reinit(rows + 3, unit.size());
            cell->get_dof_indices(dofs);
            for (unsigned int i = 0; i < dofs.size(); ++i)
              {
                const auto [component, point] = fe.system_to_component_index(i);
                for (unsigned int f = 0; f < fields.size(); ++f)
                  patch.data(3 * f + component, point) = 0. + (*fields[f])[dofs[i]]; // -0 as +0, as the sum does
              }
            for (unsigned int j = 0; j < unit.size(); ++j)
              {
                const dealii::Point<3> x = point_in_linear_tet(cell, unit[j]);
                for (unsigned int d = 0; d < 3; ++d)
                  patch.data(rows + d, j) = x[d];
              }
            this->patches.push_back(std::move(patch));
          }
      }

      std::shared_ptr<const Patches> take_patches()
      {
        auto taken = std::make_shared<Patches>(
          Patches{std::move(this->patches), get_dataset_names(), get_nonscalar_data_ranges(), flags_for_vtu});
        clear();
        return taken;
      }

    private:
      dealii::DataOutBase::VtkFlags flags_for_vtu;
    };

    // Mode shapes (frequency in the field name) and the validation error fields, for ParaView.
    template <typename Backend>
    void output_results(const Backend &b, const PhaseInputs &in, const ModalSpaceResult &result)
    {
      if (in.vtu_file.empty())
        return;
      VtuOutput data_out;
      data_out.attach_dof_handler(b.dof_handler);
      const std::vector<dealii::DataComponentInterpretation::DataComponentInterpretation> vector_field(
        3, dealii::DataComponentInterpretation::component_is_part_of_vector);
      const auto        &modes = b.kept_modes();
      const unsigned int n_vtu = std::min<unsigned int>(in.scene.output.vtu_modes, modes.size());
      std::vector<typename Backend::Field> mode_fields; // with the constrained entries filled in
      mode_fields.reserve(n_vtu);
      for (unsigned int i = 0; i < n_vtu; ++i)
        mode_fields.push_back(b.output_field(modes[i]));
      for (unsigned int i = 0; i < n_vtu; ++i)
        data_out.add_data_vector(mode_fields[i],
                                 std::vector<std::string>(3, space_parts::mode_field_name(i, result.frequencies_hz[i])),
                                 dealii::DataOut<3>::type_dof_data, vector_field);
      for (unsigned int k = 0; k < b.validation_fields.size(); ++k)
        data_out.add_data_vector(b.validation_fields[k],
                                 std::vector<std::string>(3, space_parts::validation_field_name(result.validation[k])),
                                 dealii::DataOut<3>::type_dof_data, vector_field);
      if constexpr (std::is_same_v<typename Backend::Field, dealii::Vector<double>>)
        {
          std::vector<const dealii::Vector<double> *> fields;
          for (const auto &field : mode_fields)
            fields.push_back(&field);
          for (const auto &field : b.validation_fields)
            fields.push_back(&field);
          data_out.build_patches_at_nodes(b.dof_handler, fields);
        }
      else
        data_out.build_patches(b.mapping, in.scene.element_degree);
      // 'Output/VTU compression': none by default, since zlib on one thread took more than half of
      // the phase (docs/performance.md) for files that are only viewed.
      dealii::DataOutBase::VtkFlags flags;
      switch (in.scene.output.vtu_compression)
        {
          case VtuCompression::none:
            flags.compression_level = dealii::DataOutBase::VtkFlags::no_compression;
            break;
          case VtuCompression::fast:
            flags.compression_level = dealii::DataOutBase::VtkFlags::best_speed;
            break;
          case VtuCompression::best:
            flags.compression_level = dealii::DataOutBase::VtkFlags::best_compression;
            break;
        }
      data_out.set_vtk_flags(flags);
      b.write_vtu(data_out);
    }
    // A space whose phases after the eigensolve are those above: a backend derives from
    // PhasedSpace<itself> and implements assembly and eigensolve (SpaceBase) and the operations the
    // head of this file lists.
    template <typename Backend>
    class PhasedSpace : public space_parts::SpaceBase
    {
    public:
      using SpaceBase::SpaceBase;

    protected:
      void interpolate() override
      {
        interpolate_on_display_surface(backend(), inputs(), result);
        compute_participation_factors(backend(), result);
      }
      void compute_static_correction() override { space_phases::compute_static_correction(backend(), inputs(), result); }
      void compute_far_field() override { space_phases::compute_far_field(backend(), inputs(), result); }
      void validate() override { space_phases::validate(backend(), inputs(), result); }
      void output_results() const override
      {
        space_phases::output_results(static_cast<const Backend &>(*this), inputs(), result);
      }
      void estimate_validity() override
      {
        nonlinear::estimate_validity_map(
          display, [this] { return modal_view(); }, result, [this](const std::string &line) { summarize(line); });
      }

      void analyse_validity() override
      {
        Backend &b = backend();
        nonlinear::analyse_validity(
          b.validity_space(), scene, task, display,
          [&b](const unsigned int v, const std::array<double, 3> &d) { return b.patch_load(v, d); },
          [&b](const meshing::Point3 &x) {
            double outside = 0.;
            b.evaluation_points({x}, &outside);
            return outside;
          },
          [this]() -> std::optional<nonlinear::ModalView> {
            if (scene.contact.validity_estimate)
              return modal_view();
            return std::nullopt;
          },
          result, [this](const std::string &line) { log(line); }, [this](const std::string &line) { summarize(line); });
      }

      // The validity estimate's modal side (large_deformation.h), built on first use: the cubic term
      // on the lowest modes, and B_v^T on them at every vertex with a patch load (the corrected
      // contacts and shared vertices), each process's part summed over the processes at once.
      nonlinear::ModalView modal_view()
      {
        Backend &b = backend();
        if (!cubic_term)
          {
            const auto sum = [&b](std::vector<double> &values) { b.sum_over_processes(values); };
            cubic_term     = std::make_unique<nonlinear::ModalCubicTerm>(b.dof_handler, mapping, quadrature,
                                                                     scene.material, nonlinear::validity_law(scene),
                                                                     b.ghosted_kept_modes(), sum);
            const unsigned int r = cubic_term->size();
            for (const auto &[vertex, load] : b.surface.patch_loads)
              {
                modal_load_row[vertex] = modal_loads.size() / (3 * std::size_t(r));
                for (unsigned int i = 0; i < r; ++i)
                  {
                    const auto average = b.surface.local_patch_average(vertex, b.ghosted_kept_modes()[i]);
                    modal_loads.insert(modal_loads.end(), average.begin(), average.end());
                  }
              }
            sum(modal_loads);
          }
        const std::vector<dealii::Vector<double>> *serial_modes = nullptr;
        if constexpr (std::is_same_v<typename Backend::Field, dealii::Vector<double>>)
          serial_modes = &b.kept_modes();
        return {serial_modes, *cubic_term, [this](const unsigned int vertex, const std::array<double, 3> &d) {
                  const unsigned int r   = cubic_term->size();
                  const double      *row = &modal_loads[3 * std::size_t(r) * modal_load_row.at(vertex)];
                  std::vector<double> b(r);
                  for (unsigned int i = 0; i < r; ++i)
                    b[i] = d[0] * row[3 * i] + d[1] * row[3 * i + 1] + d[2] * row[3 * i + 2];
                  return b;
                }};
      }

    private:
      Backend &backend() { return static_cast<Backend &>(*this); }

      std::unique_ptr<nonlinear::ModalCubicTerm> cubic_term;
      std::vector<double>                        modal_loads; // per vertex with a patch load: r x 3, B_v^T
      std::map<unsigned int, std::size_t>        modal_load_row;
    };
  } // namespace space_phases
} // namespace modal_haptics
