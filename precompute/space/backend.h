// The backend a modal space's phases are written over (phase_*.h): the linear algebra of one FE
// space, serial (SerialSpace, modal_space.cc: CHOLMOD or UMFPACK, deal.II vectors) or distributed
// (DistributedSpace, distributed_space.cc: Trilinos matrices, MUMPS, PARPACK), as ASPECT separates
// its assembly from its solver backends; both compute every quantity by the same phase code, so
// serial and distributed agree by construction. The phases are templates over it (a concept,
// checked where PhasedSpace<Backend> instantiates them): a call a backend lacks fails to compile.
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
//   void write_vtu(VtuOutput &) const   after build_patches (phase_output.h)
//   SurfaceOperators surface;         filled by phase_interpolation.h
//   std::vector<Field> validation_fields;   full - modal, one per validation case, as output_field gives
//
// Every field of the phases is a vector of the constrained system: zero on constrained DoFs. Loads
// and readings (display rows, patch loads) are condensed once, so they act on and read such fields
// as the full fields they stand for; only the output fills the constrained entries in.
#pragma once

#include "space/space_parts.h"

#include <deal.II/base/parallel.h>

#include <algorithm>
#include <array>
#include <map>
#include <utility>
#include <vector>

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

    class VtuOutput; // phase_output.h
  } // namespace space_phases
} // namespace modal_haptics
