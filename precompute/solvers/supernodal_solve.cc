#include "solvers/supernodal_solve.h"

#include "solvers/blas_lapack.h"
#include "solvers/supernode_tree.h"

#include <algorithm>
#include <array>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>

namespace modal_haptics
{
  SupernodalSolve::SupernodalSolve(const cholmod_factor &factor, const unsigned int threads)
    : n(factor.n)
    , n_supernodes(factor.nsuper)
    , max_rows_below(factor.maxesize)
    , first_column(static_cast<const Index *>(factor.super))
    , row_start(static_cast<const Index *>(factor.pi))
    , value_start(static_cast<const Index *>(factor.px))
    , rows(static_cast<const Index *>(factor.s))
    , permutation(static_cast<const Index *>(factor.Perm))
    , values(static_cast<const double *>(factor.x))
  {
    if (!factor.is_super || !factor.is_ll || factor.xtype != CHOLMOD_REAL || factor.itype != CHOLMOD_LONG)
      throw std::invalid_argument("SupernodalSolve needs a real numeric supernodal L L^T factor (factorize_supernodal).");
    for (Index s = 0; s < n_supernodes; ++s)
      max_rows = std::max(max_rows, row_start[s + 1] - row_start[s]);
    assign_subtrees(factor, std::max(1u, threads));
  }

  // Splits the elimination tree of the supernodes into subtrees for the threads, weighed by their
  // entries of L (what a solve reads): split_tree.
  void SupernodalSolve::assign_subtrees(const cholmod_factor &factor, const unsigned int threads)
  {
    SupernodeTree       tree = supernode_tree(factor);
    std::vector<double> entries(n_supernodes);
    for (Index s = 0; s < n_supernodes; ++s)
      entries[s] = double(row_start[s + 1] - row_start[s]) * double(first_column[s + 1] - first_column[s]);
    TreeSplit split        = split_tree(tree, entries, threads);
    total_entries          = split.total_weight;
    top_entries            = split.top_weight;
    largest_thread_entries = split.largest_thread_weight;
    supernode_of_column    = std::move(tree.supernode_of_column);
    parent_supernode       = std::move(tree.parent);
    subtrees_of_thread     = std::move(split.subtrees_of_thread);
    top_supernodes         = std::move(split.top);
    top_position.assign(n, -1);
    for (const Index s : top_supernodes)
      for (Index c = first_column[s]; c < first_column[s + 1]; ++c)
        top_position[c] = n_top_columns++;
  }

  // One supernode's block of L: its columns' diagonal triangle L11 (n_columns x n_columns, at L)
  // above L21 (below x n_columns, at L + n_columns; rows_below are their rows), column-major with
  // leading dimension n_rows; its columns are first .. first + n_columns - 1.
  struct SupernodalSolve::Block
  {
    Block(const SupernodalSolve &solve, const Index supernode)
      : first(solve.first_column[supernode])
      , n_columns(solve.first_column[supernode + 1] - first)
      , n_rows(solve.row_start[supernode + 1] - solve.row_start[supernode])
      , below(n_rows - n_columns)
      , L(solve.values + solve.value_start[supernode])
      , rows_below(solve.rows + solve.row_start[supernode] + n_columns)
    {}

    const Index   first;
    const int     n_columns, n_rows, below;
    const double *L;
    const Index  *rows_below;
  };

  bool SupernodalSolve::solve_own_rows(const Block &b, double *own, const int ld, const int n_rhs,
                                       double *workspace) const
  {
    const double one = 1., zero = 0.;
    dtrsm_("L", "L", "N", "N", &b.n_columns, &n_rhs, &one, b.L, &b.n_rows, own, &ld);
    if (b.below == 0)
      return false;
    dgemm_("N", "N", &b.below, &n_rhs, &b.n_columns, &one, b.L + b.n_columns, &b.n_rows, own, &ld, &zero,
           workspace, &b.below);
    return true;
  }

  void SupernodalSolve::forward(const Index supernode, double *X, const int n_rhs, double *workspace,
                                double *top_updates) const
  {
    const Block b(*this, supernode);
    if (!solve_own_rows(b, X + b.first, int(n), n_rhs, workspace))
      return;
    // The updates scattered onto the rows below (ancestors' columns).
    for (int c = 0; c < n_rhs; ++c)
      for (int i = 0; i < b.below; ++i)
        {
          const Index  row    = b.rows_below[i];
          const double update = workspace[i + std::size_t(c) * b.below];
          const Index  top    = top_updates != nullptr ? top_position[row] : -1;
          if (top >= 0)
            top_updates[top + std::size_t(c) * n_top_columns] -= update;
          else
            X[row + std::size_t(c) * n] -= update;
        }
  }

  void SupernodalSolve::backward(const Index supernode, double *X, const int n_rhs, double *workspace) const
  {
    const Block  b(*this, supernode);
    const int    ld  = int(n);
    double      *own = X + b.first;
    const double one = 1., minus_one = -1.;
    if (b.below > 0)
      {
        // x_own -= L21^T x_below, x_below gathered into the workspace.
        for (int c = 0; c < n_rhs; ++c)
          for (int i = 0; i < b.below; ++i)
            workspace[i + std::size_t(c) * b.below] = X[b.rows_below[i] + std::size_t(c) * n];
        dgemm_("T", "N", &b.n_columns, &n_rhs, &b.below, &minus_one, b.L + b.n_columns, &b.n_rows, workspace, &b.below,
               &one, own, &ld);
      }
    dtrsm_("L", "L", "T", "N", &b.n_columns, &n_rhs, &one, b.L, &b.n_rows, own, &ld);
  }

// The narrow kernels pay only with 256-bit vectors and fused multiply-adds (x86-64-v3: AVX2, FMA;
// with SSE2 alone they were no faster than the BLAS): they are compiled for them, and solve()
// takes them only where the processor has them (narrow_kernels_run_here). Elsewhere than on x86-64
// (unmeasured) the BLAS solves every width.
#if defined(__x86_64__)
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif
  namespace
  {
    // The narrow kernels work on one supernode's rows gathered into x, row-interleaved (x[i * width
    // + c]: a row's right-hand sides side by side), and read each entry of L once, column after
    // column. x's first n_columns rows are the supernode's own, the rest its rows below.

    // L11 y = x_own, then x_below -= L21 y; two columns of L at a time, so that x below them is
    // read and written once for both. (__restrict: x never aliases L, which lets the compiler
    // keep L's entries in registers and vectorize across the right-hand sides.)
    template <int width>
    void lower_sweep(const double *__restrict L, const int n_columns, const int n_rows, double *__restrict x)
    {
      int j = 0;
      for (; j + 2 <= n_columns; j += 2)
        {
          const double *__restrict first = L + std::size_t(j) * n_rows, *__restrict second = first + n_rows;
          double y0[width], y1[width];
          for (int c = 0; c < width; ++c)
            {
              y0[c] = x[j * width + c] /= first[j];
              y1[c] = x[(j + 1) * width + c] = (x[(j + 1) * width + c] - first[j + 1] * y0[c]) / second[j + 1];
            }
          for (int i = j + 2; i < n_rows; ++i)
            {
              const double l0 = first[i], l1 = second[i];
              for (int c = 0; c < width; ++c)
                x[i * width + c] -= l0 * y0[c] + l1 * y1[c];
            }
        }
      if (j < n_columns)
        {
          const double *__restrict column = L + std::size_t(j) * n_rows;
          double y[width];
          for (int c = 0; c < width; ++c)
            y[c] = x[j * width + c] /= column[j];
          for (int i = j + 1; i < n_rows; ++i)
            {
              const double l = column[i];
              for (int c = 0; c < width; ++c)
                x[i * width + c] -= l * y[c];
            }
        }
    }

    // L11^T z = x_own - L21^T x_below, from the last column: each a dot product of its column
    // with x below the diagonal, two columns at a time (x read once for both), each in two partial
    // sums (one sum would wait on the latency of every multiply-add).
    template <int width>
    void transposed_sweep(const double *__restrict L, const int n_columns, const int n_rows, double *__restrict x)
    {
      int j = n_columns - 1;
      for (; j >= 1; j -= 2)
        {
          // Columns j (second) and j - 1 (first): both their sums over the rows below j first.
          const double *__restrict second = L + std::size_t(j) * n_rows, *__restrict first = second - n_rows;
          double sum0[2][width] = {}, sum1[2][width] = {};
          int    i = j + 1;
          for (; i + 2 <= n_rows; i += 2)
            for (int u = 0; u < 2; ++u)
              {
                const double l0 = first[i + u], l1 = second[i + u];
                for (int c = 0; c < width; ++c)
                  {
                    sum0[u][c] += l0 * x[(i + u) * width + c];
                    sum1[u][c] += l1 * x[(i + u) * width + c];
                  }
              }
          for (; i < n_rows; ++i)
            for (int c = 0; c < width; ++c)
              {
                sum0[0][c] += first[i] * x[i * width + c];
                sum1[0][c] += second[i] * x[i * width + c];
              }
          for (int c = 0; c < width; ++c)
            {
              const double z = x[j * width + c] = (x[j * width + c] - (sum1[0][c] + sum1[1][c])) / second[j];
              x[(j - 1) * width + c] = (x[(j - 1) * width + c] - (sum0[0][c] + sum0[1][c]) - first[j] * z) / first[j - 1];
            }
        }
      if (j == 0)
        {
          double sum[width] = {};
          for (int i = 1; i < n_rows; ++i)
            for (int c = 0; c < width; ++c)
              sum[c] += L[i] * x[i * width + c];
          for (int c = 0; c < width; ++c)
            x[c] = (x[c] - sum[c]) / L[0];
        }
    }
  } // namespace

  template <int width>
  void SupernodalSolve::forward_narrow(const Index supernode, double *X, double *rows_of_block, double *top_updates) const
  {
    const Block b(*this, supernode);
    double     *own = X + std::size_t(b.first) * width;
    std::copy(own, own + b.n_columns * width, rows_of_block);
    std::fill(rows_of_block + b.n_columns * width, rows_of_block + b.n_rows * width, 0.);
    lower_sweep<width>(b.L, b.n_columns, b.n_rows, rows_of_block);
    std::copy(rows_of_block, rows_of_block + b.n_columns * width, own);
    // rows_of_block below the own rows: -L21 y, added to the rows below (or to the top's updates).
    for (int i = 0; i < b.below; ++i)
      {
        const Index   row    = b.rows_below[i];
        const Index   top    = top_updates != nullptr ? top_position[row] : -1;
        double       *target = top >= 0 ? top_updates + std::size_t(top) * width : X + std::size_t(row) * width;
        const double *update = rows_of_block + (b.n_columns + i) * width;
        for (int c = 0; c < width; ++c)
          target[c] += update[c];
      }
  }

  template <int width>
  void SupernodalSolve::backward_narrow(const Index supernode, double *X, double *rows_of_block) const
  {
    const Block b(*this, supernode);
    double     *own = X + std::size_t(b.first) * width;
    std::copy(own, own + b.n_columns * width, rows_of_block);
    for (int i = 0; i < b.below; ++i)
      std::copy_n(X + std::size_t(b.rows_below[i]) * width, width, rows_of_block + (b.n_columns + i) * width);
    transposed_sweep<width>(b.L, b.n_columns, b.n_rows, rows_of_block);
    std::copy(rows_of_block, rows_of_block + b.n_columns * width, own);
  }

#if defined(__x86_64__)
#pragma GCC pop_options
#endif

  namespace
  {
    bool narrow_kernels_run_here()
    {
#if defined(__x86_64__)
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
      return false;
#endif
    }
  } // namespace

  // P b in, P^T x out; in between L y = P b (the subtrees on their threads, each adding its
  // updates to the top's rows into its own top_updates, laid out as X; then those summed into X
  // and the top solved) and L^T x = y (the top, then the subtrees at once: each reads only its
  // own rows and the top's). X is column-major (interleaved = false) or row-interleaved.
  template <typename Forward, typename Backward>
  void SupernodalSolve::solve_in_tree_order(double *columns, const unsigned int n_rhs, const bool interleaved,
                                            const Forward &forward_step, const Backward &backward_step) const
  {
    const unsigned int threads = n_threads();
    // Row r, right-hand side c of an array with 'length' rows.
    const auto at = [&](const std::size_t length, const std::size_t r, const std::size_t c) {
      return interleaved ? r * n_rhs + c : r + c * length;
    };
    const std::size_t   length = n;
    std::vector<double> X(length * n_rhs);
    for (std::size_t c = 0; c < n_rhs; ++c)
      for (Index i = 0; i < n; ++i)
        X[at(length, i, c)] = columns[permutation[i] + c * length];
    std::vector<std::vector<double>> top_updates(threads, std::vector<double>(std::size_t(n_top_columns) * n_rhs, 0.));

    run_on_threads(threads, [&](const unsigned int t) {
      for (const Index s : subtrees_of_thread[t])
        forward_step(s, X.data(), t, top_updates[t].data());
    });
    for (const Index s : top_supernodes)
      for (Index column = first_column[s]; column < first_column[s + 1]; ++column)
        for (std::size_t c = 0; c < n_rhs; ++c)
          for (unsigned int t = 0; t < threads; ++t)
            X[at(length, column, c)] += top_updates[t][at(n_top_columns, top_position[column], c)];
    for (const Index s : top_supernodes)
      forward_step(s, X.data(), 0, nullptr);

    for (auto s = top_supernodes.rbegin(); s != top_supernodes.rend(); ++s)
      backward_step(*s, X.data(), 0);
    run_on_threads(threads, [&](const unsigned int t) {
      for (auto s = subtrees_of_thread[t].rbegin(); s != subtrees_of_thread[t].rend(); ++s)
        backward_step(*s, X.data(), t);
    });

    for (std::size_t c = 0; c < n_rhs; ++c)
      for (Index i = 0; i < n; ++i)
        columns[permutation[i] + c * length] = X[at(length, i, c)];
  }

  template <int width>
  void SupernodalSolve::solve_narrow(double *columns) const
  {
    std::vector<std::vector<double>> rows_of_block(n_threads(), std::vector<double>(std::size_t(max_rows) * width));
    solve_in_tree_order(
      columns, width, true,
      [&](const Index s, double *X, const unsigned int t, double *top) {
        forward_narrow<width>(s, X, rows_of_block[t].data(), top);
      },
      [&](const Index s, double *X, const unsigned int t) { backward_narrow<width>(s, X, rows_of_block[t].data()); });
  }

  // Up to four right-hand sides, the narrow kernels: per supernode the BLAS would run a TRSM and
  // a GEMM a few columns wide, whose call and packing overheads bound them (bench-static-correction:
  // docs/performance.md, "The triangular solves on subtrees"). Wider blocks go to the BLAS, which is
  // faster there.
  void SupernodalSolve::solve(double *columns, const unsigned int n_rhs) const
  {
    if (n_rhs == 0 || n == 0)
      return;
    static const bool narrow_kernels = narrow_kernels_run_here();
    if (narrow_kernels)
      switch (n_rhs)
      {
        case 1:
          return solve_narrow<1>(columns);
        case 2:
          return solve_narrow<2>(columns);
        case 3:
          {
            // Padded to four (a zero column): rows of three doubles do not fill the vectors, and
            // width 3 was slower than 4 (docs/performance.md).
            std::vector<double> padded(std::size_t(n) * 4, 0.);
            std::copy(columns, columns + std::size_t(n) * 3, padded.begin());
            solve_narrow<4>(padded.data());
            std::copy(padded.begin(), padded.begin() + std::size_t(n) * 3, columns);
            return;
          }
        case 4:
          return solve_narrow<4>(columns);
        default:
          break;
      }
    std::vector<std::vector<double>> workspace(n_threads(),
                                               std::vector<double>(std::max<Index>(max_rows_below, 1) * n_rhs));
    solve_in_tree_order(
      columns, n_rhs, false,
      [&](const Index s, double *X, const unsigned int t, double *top) {
        forward(s, X, int(n_rhs), workspace[t].data(), top);
      },
      [&](const Index s, double *X, const unsigned int t) { backward(s, X, int(n_rhs), workspace[t].data()); });
  }

  void SupernodalSolve::mark_paths(const std::vector<SparseColumn> &B, const std::vector<Index> &position_of_row,
                                   std::vector<char> &on_path, std::vector<Index> &path) const
  {
    for (const auto &column : B)
      mark_path(column, position_of_row, on_path, path);
  }

  void SupernodalSolve::mark_path(const SparseColumn &column, const std::vector<Index> &position_of_row,
                                  std::vector<char> &on_path, std::vector<Index> &path) const
  {
    for (const auto &entry : column)
      // Up the tree until a supernode already on a path (the rest of its path is too).
      for (Index s = supernode_of_column[position_of_row[entry.first]]; s >= 0 && !on_path[s]; s = parent_supernode[s])
        {
          on_path[s] = 1;
          path.push_back(s);
        }
  }

  void SupernodalSolve::forward_local(const Index supernode, double *X, const int ld, const Index *local_row,
                                      const int *active, const int n_active, double *own, double *workspace,
                                      GroupGram &gram) const
  {
    const Block b(*this, supernode);
    // A supernode's columns are consecutive rows of X. Where every column is active they are solved
    // in place; otherwise the active columns' rows are gathered into 'own' and put back.
    const bool all  = n_active == gram.width;
    double    *rows = X + local_row[b.first];
    if (!all)
      for (int c = 0; c < n_active; ++c)
        std::copy_n(rows + std::size_t(active[c]) * ld, b.n_columns, own + std::size_t(c) * b.n_columns);
    const bool has_below = solve_own_rows(b, all ? rows : own, all ? ld : b.n_columns, n_active, workspace);
    add_to_gram(all ? rows : own, b.n_columns, all ? ld : b.n_columns, active, n_active, gram);
    if (!all)
      for (int c = 0; c < n_active; ++c)
        std::copy_n(own + std::size_t(c) * b.n_columns, b.n_columns, rows + std::size_t(active[c]) * ld);
    if (!has_below)
      return;
    for (int c = 0; c < n_active; ++c)
      {
        double       *column  = X + std::size_t(all ? c : active[c]) * ld;
        const double *updates = workspace + std::size_t(c) * b.below;
        for (int i = 0; i < b.below; ++i)
          column[local_row[b.rows_below[i]]] -= updates[i];
      }
  }

  void SupernodalSolve::add_to_gram(const double *rows, const int n_rows, const int ld, const int *active,
                                    const int n_active, GroupGram &gram) const
  {
    // The active columns ascend, so the leading ones among them come first.
    const int    m   = int(std::lower_bound(active, active + n_active, gram.n_leading) - active);
    const double one = 1., zero = 0.;
    if (m == 0 || n_rows == 0)
      return;
    if (n_active == gram.width) // every column: straight into G
      {
        dgemm_("T", "N", &n_active, &m, &n_rows, &one, rows, &ld, rows, &ld, &one, gram.G.data(), &gram.width);
        return;
      }
    gram.part.resize(std::size_t(n_active) * m);
    dgemm_("T", "N", &n_active, &m, &n_rows, &one, rows, &ld, rows, &ld, &zero, gram.part.data(), &n_active);
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < n_active; ++i)
        gram.G[active[i] + std::size_t(active[j]) * gram.width] += gram.part[i + std::size_t(j) * n_active];
  }

  std::vector<std::vector<int>> SupernodalSolve::active_columns(const std::vector<SparseColumn> &B,
                                                                const std::vector<Index> &path,
                                                                const std::vector<Index> &position_of_row,
                                                                GroupScratch &scratch) const
  {
    for (std::size_t i = 0; i < path.size(); ++i)
      scratch.path_position[path[i]] = Index(i);
    std::vector<std::vector<int>> active(path.size());
    std::vector<Index>            own_path;
    for (int k = 0; k < int(B.size()); ++k)
      {
        own_path.clear();
        mark_path(B[k], position_of_row, scratch.on_path, own_path);
        for (const Index s : own_path)
          {
            scratch.on_path[s] = 0;
            if (scratch.path_position[s] >= 0)
              active[scratch.path_position[s]].push_back(k);
          }
      }
    for (const Index s : path)
      scratch.path_position[s] = -1;
    return active;
  }

  std::vector<double> SupernodalSolve::group_gram(const std::vector<SparseColumn> &B, const std::size_t leading,
                                                  const std::vector<Index> &position_of_row, GroupScratch &scratch,
                                                  SolvedGroup *solved) const
  {
    const int          width = int(B.size());
    auto              &local_row = scratch.local_row;
    std::vector<Index> path;
    mark_paths(B, position_of_row, scratch.on_path, path);
    for (const Index s : path)
      scratch.on_path[s] = 0;
    std::sort(path.begin(), path.end()); // children before parents: the order of a forward solve
    Index rows_of_Y = 0;
    for (const Index s : path)
      for (Index column = first_column[s]; column < first_column[s + 1]; ++column)
        local_row[column] = rows_of_Y++;
    const int           ld = int(std::max<Index>(rows_of_Y, 1));
    std::vector<double> X(std::size_t(ld) * std::max(width, 1), 0.);
    for (int k = 0; k < width; ++k)
      for (const auto &[row, value] : B[k])
        X[local_row[position_of_row[row]] + std::size_t(k) * ld] += value;
    // The union of the columns' paths is several times the work of each column's own path (3.5x on
    // the default scene's rib_b): each supernode solves only the columns whose path it is on.
    const auto          active = active_columns(B, path, position_of_row, scratch);
    const std::size_t   width_or_1 = std::max(width, 1);
    std::vector<double> workspace(std::max<Index>(max_rows_below, 1) * width_or_1);
    int                 max_own_rows = 1;
    for (const Index s : path)
      max_own_rows = std::max<int>(max_own_rows, first_column[s + 1] - first_column[s]);
    std::vector<double> own(std::size_t(max_own_rows) * width_or_1);
    // G = Y^T Y, each supernode's rows added as soon as they are solved.
    GroupGram gram{std::vector<double>(std::size_t(width) * leading, 0.), width, int(leading), {}};
    for (std::size_t i = 0; i < path.size(); ++i)
      if (!active[i].empty())
        forward_local(path[i], X.data(), ld, local_row.data(), active[i].data(), int(active[i].size()), own.data(),
                      workspace.data(), gram);
    if (solved != nullptr)
      {
        solved->offset.resize(path.size());
        for (std::size_t i = 0; i < path.size(); ++i)
          solved->offset[i] = local_row[first_column[path[i]]];
        solved->path = std::move(path);
        solved->ld   = ld;
        solved->Y    = std::move(X);
      }
    return std::move(gram.G);
  }

  double SupernodalSolve::solved_groups_bytes(const std::vector<GramGroup> &groups,
                                              const std::vector<Index> &position_of_row) const
  {
    std::vector<char>  on_path(n_supernodes, 0);
    std::vector<Index> path;
    double             bytes = 0.;
    for (const auto &group : groups)
      {
        path.clear();
        mark_paths(group.columns, position_of_row, on_path, path);
        Index rows_of_Y = 0;
        for (const Index s : path)
          {
            on_path[s] = 0;
            rows_of_Y += first_column[s + 1] - first_column[s];
          }
        bytes += 8. * double(std::max<Index>(rows_of_Y, 1)) * double(group.columns.size());
      }
    return bytes;
  }

  void SupernodalSolve::add_borrowed_rows(const GramGroup &group, const SolvedGroup &own,
                                          const std::vector<SolvedGroup> &solved, std::vector<double> &gram) const
  {
    const int width = int(group.columns.size()), rows_of_G = width + int(group.borrowed.size());
    // The borrowed columns by lending group: one product per lender, with the own columns that
    // any of them is wanted with (the default scene: about a third of the group's).
    std::map<std::size_t, std::vector<int>> by_lender; // lender -> positions in group.borrowed
    for (int k = 0; k < int(group.borrowed.size()); ++k)
      by_lender[group.borrowed[k].first].push_back(k);
    std::vector<double> mine, theirs, product;
    std::vector<int>    wanted;
    for (const auto &[lender, positions] : by_lender)
      {
        wanted.clear();
        for (const int k : positions)
          wanted.insert(wanted.end(), group.wanted[k].begin(), group.wanted[k].end());
        std::sort(wanted.begin(), wanted.end());
        wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
        // The rows both Y may be nonzero on: the supernodes on both paths (each ascending).
        const SolvedGroup &other = solved[lender];
        std::vector<std::array<Index, 3>> shared; // supernode's first row in own Y, in other's Y, row count
        Index rows_shared = 0;
        for (std::size_t i = 0, j = 0; i < own.path.size() && j < other.path.size();)
          if (own.path[i] < other.path[j])
            ++i;
          else if (other.path[j] < own.path[i])
            ++j;
          else
            {
              const Index s = own.path[i];
              shared.push_back({{own.offset[i], other.offset[j], first_column[s + 1] - first_column[s]}});
              rows_shared += shared.back()[2];
              ++i, ++j;
            }
        if (rows_shared == 0 || wanted.empty()) // paths apart: the products are zero
          continue;
        const int k = int(positions.size()), w = int(wanted.size()), m = int(rows_shared);
        mine.resize(std::size_t(m) * w);
        theirs.resize(std::size_t(m) * k);
        Index row = 0;
        for (const auto &[at_own, at_other, count] : shared)
          {
            for (int c = 0; c < w; ++c)
              std::copy_n(&own.Y[at_own + std::size_t(wanted[c]) * own.ld], count, &mine[row + std::size_t(c) * m]);
            for (int c = 0; c < k; ++c)
              std::copy_n(&other.Y[at_other + group.borrowed[positions[c]].second * std::size_t(other.ld)], count,
                          &theirs[row + std::size_t(c) * m]);
            row += count;
          }
        // The borrowed rows of G: theirs^T mine (k x w).
        product.resize(std::size_t(k) * w);
        const double one = 1., zero = 0.;
        dgemm_("T", "N", &k, &w, &m, &one, theirs.data(), &m, mine.data(), &m, &zero, product.data(), &k);
        for (int j = 0; j < w; ++j)
          for (int c = 0; c < k; ++c)
            gram[width + positions[c] + std::size_t(wanted[j]) * rows_of_G] = product[c + std::size_t(j) * k];
      }
  }

  std::vector<std::vector<double>> SupernodalSolve::group_grams(const std::vector<GramGroup> &groups,
                                                               const double storage_limit) const
  {
    std::vector<Index> position_of_row(n);
    for (Index i = 0; i < n; ++i)
      position_of_row[permutation[i]] = i;
    std::vector<std::vector<double>> grams(groups.size());
    const unsigned int               threads = n_threads();
    bool borrows = false;
    for (const auto &group : groups)
      {
        if (group.wanted.size() != group.borrowed.size())
          throw std::invalid_argument("group_grams: a GramGroup needs one 'wanted' list per borrowed column.");
        borrows = borrows || !group.borrowed.empty();
      }
    if (borrows && solved_groups_bytes(groups, position_of_row) > storage_limit)
      {
        // Each borrowed column solved again in the group that borrows it.
        run_on_threads(threads, [&](const unsigned int t) {
          GroupScratch scratch(*this);
          for (std::size_t g = t; g < groups.size(); g += threads)
            {
              std::vector<SparseColumn> B = groups[g].columns;
              for (const auto &[lender, column] : groups[g].borrowed)
                B.push_back(groups[lender].columns[column]);
              grams[g] = group_gram(B, groups[g].columns.size(), position_of_row, scratch, nullptr);
            }
        });
        return grams;
      }
    std::vector<SolvedGroup> solved(borrows ? groups.size() : 0);
    run_on_threads(threads, [&](const unsigned int t) {
      GroupScratch scratch(*this);
      for (std::size_t g = t; g < groups.size(); g += threads)
        grams[g] = group_gram(groups[g].columns, groups[g].columns.size(), position_of_row, scratch,
                              borrows ? &solved[g] : nullptr);
    });
    if (!borrows)
      return grams;
    run_on_threads(threads, [&](const unsigned int t) {
      for (std::size_t g = t; g < groups.size(); g += threads)
        {
          if (groups[g].borrowed.empty())
            continue;
          // The own Gram's rows, then room for the borrowed ones.
          const std::size_t   width = groups[g].columns.size(), rows_of_G = width + groups[g].borrowed.size();
          std::vector<double> G(rows_of_G * width, 0.);
          for (std::size_t j = 0; j < width; ++j)
            std::copy_n(&grams[g][j * width], width, &G[j * rows_of_G]);
          add_borrowed_rows(groups[g], solved[g], solved, G);
          grams[g] = std::move(G);
        }
    });
    return grams;
  }
} // namespace modal_haptics
