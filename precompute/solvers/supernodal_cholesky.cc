#include "solvers/supernodal_cholesky.h"

#include "solvers/blas_lapack.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace modal_haptics
{
  namespace
  {
    using Index = SupernodeIndex;

    // An update of a supernode by one below it (its descendant d): d's rows [begin, end) (offsets in
    // d's row list) are the supernode's columns, and d's rows from 'begin' on receive it.
    struct Update
    {
      Index descendant;
      int   begin, end;
    };

    // What one thread keeps between its supernodes.
    struct Workspace
    {
      // largest_update: the most rows an update reaches and the most entries it has.
      Workspace(const Index n, const std::pair<std::size_t, std::size_t> largest_update)
        : local_row(n, -1)
        , owner(n, -1)
        , relative_row(largest_update.first)
        , update(largest_update.second)
      {}
      std::vector<Index> local_row;    // per row of the factor: its place in the current supernode's rows
      std::vector<Index> owner;        // per row: the supernode local_row was set for
      std::vector<Index> relative_row; // per row of an update: its place in the supernode's rows
      std::vector<double> update;      // an update's block, before it is scattered
    };

    class LeftLookingCholesky
    {
    public:
      LeftLookingCholesky(const cholmod_sparse &A, cholmod_factor &factor)
        : n(factor.n)
        , n_supernodes(factor.nsuper)
        , first_column(static_cast<const Index *>(factor.super))
        , row_start(static_cast<const Index *>(factor.pi))
        , value_start(static_cast<const Index *>(factor.px))
        , rows(static_cast<const Index *>(factor.s))
        , values(static_cast<double *>(factor.x))
        , A_column_start(static_cast<const Index *>(A.p))
        , A_rows(static_cast<const Index *>(A.i))
        , A_values(static_cast<const double *>(A.x))
        , position_of_row(n)
      {
        const auto *permutation = static_cast<const Index *>(factor.Perm);
        for (Index k = 0; k < n; ++k)
          position_of_row[permutation[k]] = k;
        column_of_position.assign(permutation, permutation + n);
        plan_updates();
      }

      // The flops of each supernode: its own POTRF and TRSM, and the updates it gathers.
      const std::vector<double> &flops() const { return supernode_flops; }

      // Factorizes the supernodes in ascending order, stopping before any that starts after the
      // first failure found so far by any thread (shared in first_failure, a column).
      void factorize(const std::vector<Index> &supernodes, std::atomic<Index> &first_failure) const
      {
        Workspace workspace(n, largest_updates(supernodes));
        for (const Index s : supernodes)
          {
            if (first_column[s] > first_failure.load())
              return;
            const int failed_at = factorize_supernode(s, workspace);
            if (failed_at >= 0)
              {
                Index seen = first_failure.load();
                while (first_column[s] + failed_at < seen &&
                       !first_failure.compare_exchange_weak(seen, first_column[s] + failed_at))
                  ;
                return;
              }
          }
      }

    private:
      // The most rows and entries an update of these supernodes has (a thread's workspace: the
      // subtrees' updates are much smaller than the top's).
      std::pair<std::size_t, std::size_t> largest_updates(const std::vector<Index> &supernodes) const
      {
        std::size_t rows_receiving = 0, entries = 0;
        for (const Index s : supernodes)
          for (std::size_t u = update_start[s]; u < update_start[s + 1]; ++u)
            {
              const std::size_t receiving = n_rows_of(updates[u].descendant) - updates[u].begin;
              rows_receiving              = std::max(rows_receiving, receiving);
              entries = std::max(entries, receiving * std::size_t(updates[u].end - updates[u].begin));
            }
        return {rows_receiving, entries};
      }

      Index n_columns_of(const Index s) const { return first_column[s + 1] - first_column[s]; }
      Index n_rows_of(const Index s) const { return row_start[s + 1] - row_start[s]; }

      // The updates of every supernode, from the row lists of the supernodes below it (a
      // supernode's rows below its own columns are ascending), and the flops they cost.
      void plan_updates()
      {
        std::vector<std::vector<Update>> updates_of(n_supernodes);
        supernode_flops.assign(n_supernodes, 0.);
        std::vector<Index> supernode_of_column(n);
        for (Index s = 0; s < n_supernodes; ++s)
          std::fill(supernode_of_column.begin() + first_column[s], supernode_of_column.begin() + first_column[s + 1], s);
        for (Index d = 0; d < n_supernodes; ++d)
          {
            const Index  n_columns = n_columns_of(d), n_rows = n_rows_of(d);
            const Index *d_rows    = rows + row_start[d];
            supernode_flops[d] += double(n_columns) * n_columns * (n_columns / 3. + double(n_rows - n_columns));
            for (Index begin = n_columns; begin < n_rows;)
              {
                const Index s   = supernode_of_column[d_rows[begin]];
                Index       end = begin;
                while (end < n_rows && d_rows[end] < first_column[s + 1])
                  ++end;
                updates_of[s].push_back({d, int(begin), int(end)});
                const double n_receiving = double(n_rows - begin), n_own = double(end - begin);
                supernode_flops[s] += (2. * n_receiving - n_own) * n_own * double(n_columns);
                begin = end;
              }
          }
        update_start.assign(1, 0);
        for (const auto &list : updates_of)
          {
            updates.insert(updates.end(), list.begin(), list.end());
            update_start.push_back(updates.size());
          }
      }

      // Returns -1, or the column (counted from the supernode's first) where POTRF found the
      // diagonal block not positive definite.
      int factorize_supernode(const Index s, Workspace &workspace) const
      {
        const int n_columns = int(n_columns_of(s)), n_rows = int(n_rows_of(s));
        double   *L         = values + value_start[s];
        for (int i = 0; i < n_rows; ++i)
          {
            workspace.local_row[rows[row_start[s] + i]] = i;
            workspace.owner[rows[row_start[s] + i]]     = s;
          }
        gather_columns(s, L, n_rows, workspace);
        for (std::size_t u = update_start[s]; u < update_start[s + 1]; ++u)
          subtract_update(s, updates[u], L, n_rows, workspace);
        int info = 0;
        dpotrf_("L", &n_columns, L, &n_rows, &info);
        if (info != 0)
          return info - 1;
        const int    below = n_rows - n_columns;
        const double one   = 1.;
        if (below > 0)
          dtrsm_("R", "L", "T", "N", &below, &n_columns, &one, L, &n_rows, L + n_columns, &n_rows);
        return -1;
      }

      // The supernode's columns of P A P^T (on and below the diagonal) into its block, zeros elsewhere.
      void gather_columns(const Index s, double *L, const int n_rows, const Workspace &workspace) const
      {
        std::fill(L, L + std::size_t(n_rows) * n_columns_of(s), 0.);
        for (Index k = first_column[s]; k < first_column[s + 1]; ++k)
          {
            double     *column = L + std::size_t(k - first_column[s]) * n_rows;
            const Index j      = column_of_position[k];
            for (Index p = A_column_start[j]; p < A_column_start[j + 1]; ++p)
              if (const Index row = position_of_row[A_rows[p]]; row >= k)
                {
                  if (workspace.owner[row] != s)
                    throw std::runtime_error("The matrix has an entry (row " + std::to_string(A_rows[p]) + ", column " +
                                             std::to_string(j) + ") outside the pattern it was analysed with: "
                                             "the factorization needs both triangles of a symmetric pattern.");
                  column[workspace.local_row[row]] += A_values[p];
                }
          }
      }

      // L_s -= L_d[begin.., :] L_d[begin..end, :]^T on the supernode's rows: the update block (rows
      // of d from 'begin' on x the supernode's columns among them) by SYRK on its diagonal part and
      // GEMM below, then scattered.
      void subtract_update(const Index s, const Update &u, double *L, const int n_rows, Workspace &workspace) const
      {
        const Index   d          = u.descendant;
        const int     d_columns  = int(n_columns_of(d)), d_rows = int(n_rows_of(d));
        const double *L_d        = values + value_start[d];
        const Index  *rows_d     = rows + row_start[d];
        const int     n_own      = u.end - u.begin, n_receiving = d_rows - u.begin, n_further = n_receiving - n_own;
        double       *C          = workspace.update.data();
        const double  one = 1., zero = 0.;
        dsyrk_("L", "N", &n_own, &d_columns, &one, L_d + u.begin, &d_rows, &zero, C, &n_receiving);
        if (n_further > 0)
          dgemm_("N", "T", &n_further, &n_own, &d_columns, &one, L_d + u.end, &d_rows, L_d + u.begin, &d_rows, &zero,
                 C + n_own, &n_receiving);
        Index *relative = workspace.relative_row.data();
        for (int i = 0; i < n_receiving; ++i)
          relative[i] = workspace.local_row[rows_d[u.begin + i]];
        for (int j = 0; j < n_own; ++j)
          {
            double       *column = L + std::size_t(rows_d[u.begin + j] - first_column[s]) * n_rows;
            const double *c      = C + std::size_t(j) * n_receiving;
            for (int i = j; i < n_receiving; ++i)
              column[relative[i]] -= c[i];
          }
      }

      const Index          n, n_supernodes;
      const Index         *first_column, *row_start, *value_start, *rows;
      double              *values;
      const Index         *A_column_start, *A_rows;
      const double        *A_values;
      std::vector<Index>   position_of_row, column_of_position;
      std::vector<Update>  updates;      // grouped by the supernode they update
      std::vector<std::size_t> update_start; // per supernode: its first update in 'updates'
      std::vector<double>  supernode_flops;
    };
  } // namespace

  SupernodeIndex factorize_supernodal(const cholmod_sparse &A, cholmod_factor &factor, cholmod_common &common,
                                      const unsigned int threads)
  {
    if (!factor.is_super || factor.itype != CHOLMOD_LONG || A.xtype != CHOLMOD_REAL || A.itype != CHOLMOD_LONG ||
        !A.packed || A.stype <= 0 || A.nrow != factor.n || A.ncol != factor.n)
      throw std::invalid_argument("factorize_supernodal needs a supernodal analysis (cholmod_l_analyze_p) and the "
                                  "real, packed, symmetric matrix it analysed.");
    // The factor's values, laid out by the analysis (xsize doubles).
    if (!cholmod_l_change_factor(CHOLMOD_REAL, /*to_ll*/ 1, /*to_super*/ 1, /*to_packed*/ 1, /*to_monotonic*/ 1,
                                 &factor, &common) ||
        factor.x == nullptr)
      throw std::runtime_error("CHOLMOD could not allocate the factor's values (status " + std::to_string(common.status) +
                               ", out of memory?).");

    const LeftLookingCholesky cholesky(A, factor);
    const unsigned int        n_threads = std::max(1u, threads);
    const TreeSplit           split     = split_tree(supernode_tree(factor), cholesky.flops(), n_threads);
    std::atomic<Index>        first_failure(Index(factor.n));
    {
      // An error on one thread (A off the pattern, out of memory) stops the others (a failure
      // before every column) and is thrown once they are joined.
      std::vector<std::exception_ptr> errors(n_threads);
      const BlasThreads               one_blas_thread(1);
      run_on_threads(n_threads, [&](const unsigned int t) {
        try
          {
            cholesky.factorize(split.subtrees_of_thread[t], first_failure);
          }
        catch (...)
          {
            errors[t] = std::current_exception();
            first_failure.store(-1);
          }
      });
      for (const auto &error : errors)
        if (error)
          std::rethrow_exception(error);
    }
    if (first_failure.load() == Index(factor.n))
      cholesky.factorize(split.top, first_failure);
    factor.minor = first_failure.load();
    return factor.minor;
  }
} // namespace modal_haptics
