// Triangular solves with a CHOLMOD supernodal Cholesky factor (P A P^T = L L^T), with independent
// subtrees of the elimination tree on parallel threads.
//
// Why not cholmod_solve: it walks the supernodes one after the other, and per supernode runs a small
// TRSM/GEMM on a few right-hand sides whose latency, not the memory, bounds it (it reads the factor
// at a fraction of the rate one thread can read). Splitting the columns between two threads makes
// each of them read the whole factor. Here every thread takes its own subtrees, so the factor is
// read once for all the columns; only the separators above the subtrees (the top of the tree, ~8 %
// of the factor on the FACTS plate) are solved by one thread (docs/performance.md, "The triangular
// solves on subtrees"). Up to four right-hand sides go through our own narrow kernels instead of
// the BLAS.
#pragma once

#include <cholmod.h>

#include <utility>
#include <vector>

namespace modal_haptics
{
  // A sparse column: (row, value) pairs in the matrix's own numbering.
  using SparseColumn = std::vector<std::pair<std::size_t, double>>;

  // A group of sparse columns for SupernodalSolve::group_grams: its own columns, and columns of
  // other groups whose products with some of them it needs.
  struct GramGroup
  {
    std::vector<SparseColumn>                        columns;  // B_g
    std::vector<std::pair<std::size_t, std::size_t>> borrowed; // C_g: (group, its column)
    // Per borrowed column (as many lists as borrowed), the own columns (ascending) whose products
    // with it are wanted: G's other entries in its row are not computed where the borrowed solves
    // are kept (zero).
    std::vector<std::vector<std::size_t>> wanted;
  };

  class SupernodalSolve
  {
  public:
    // factor: a supernodal L L^T factor (CHOLMOD's is_super and is_ll), kept by the caller and
    // only read from here on; threads >= 1 (1: the whole tree in order on the calling thread).
    SupernodalSolve(const cholmod_factor &factor, unsigned int threads);

    // Solves A X = B in place for n_rhs columns of length n, one after the other (column-major).
    void solve(double *columns, unsigned int n_rhs) const;

    // The Gram matrices G_g = [B_g C_g]^T A^-1 B_g of groups of sparse columns B_g (|B_g| + |C_g|
    // rows, |B_g| columns, column-major): the entries of A^-1 between loads that lie close together
    // in the part (a contact's own compliance, and between neighbouring contacts) without a full
    // solve. C_g's columns are other groups' columns (GramGroup::borrowed). With P A P^T = L L^T,
    // G = Y^T Y for Y = L^-1 P B: a forward solve only, over the supernodes on the elimination
    // tree's paths from the group's nonzero rows to a root (Y is zero elsewhere). Columns close
    // together share the upper part of their paths; below, each supernode of the union solves only
    // the columns whose own path it is on (the union is 3.5x the own paths' work on the default
    // scene's rib_b). Groups go to the threads in turn; the caller keeps the BLAS on one thread.
    //
    // A borrowed column is solved once, in its own group: every group's Y is kept, and a borrowed
    // row of G is the product of the two groups' Y on the supernodes their paths share, for the own
    // columns GramGroup::wanted names (faster than solving each borrowed column again in the group
    // that borrows it; docs/performance.md). Where the kept Y of all groups would take more than
    // storage_limit bytes, the borrowed columns are solved again instead (memory per thread: a
    // group's path times its width). The top of the tree (the last separators, large and dense),
    // which every path crosses, is solved for every group too: the dense inverse of its last 3,000
    // columns, read instead (C^T (L22 L22^T)^-1 C), was no faster once each supernode solved only its
    // own columns (docs/performance.md).
    std::vector<std::vector<double>> group_grams(const std::vector<GramGroup> &groups, double storage_limit) const;

    unsigned int n_threads() const { return subtrees_of_thread.size(); }

    // The shares of the factor's entries in the top of the tree (solved by one thread) and in the
    // most loaded thread's subtrees.
    double top_share() const { return top_entries / total_entries; }
    double largest_thread_share() const { return largest_thread_entries / total_entries; }

  private:
    using Index = SuiteSparse_long;
    struct Block;

    void assign_subtrees(const cholmod_factor &factor, unsigned int threads);
    // Marks the supernodes on the paths from the nonzero rows of the columns B to the roots in
    // on_path and appends the newly marked ones to 'path' (unsorted).
    void mark_paths(const std::vector<SparseColumn> &B, const std::vector<Index> &position_of_row,
                    std::vector<char> &on_path, std::vector<Index> &path) const;
    void mark_path(const SparseColumn &column, const std::vector<Index> &position_of_row, std::vector<char> &on_path,
                   std::vector<Index> &path) const;
    // What a thread of group_grams keeps between its groups (only the entries a group set change).
    struct GroupScratch
    {
      explicit GroupScratch(const SupernodalSolve &solve)
        : local_row(solve.n, -1)
        , on_path(solve.n_supernodes, 0)
        , path_position(solve.n_supernodes, -1)
      {}
      std::vector<Index> local_row;     // per column of the factor: its row in the group's X, or -1
      std::vector<char>  on_path;       // per supernode, while paths are marked
      std::vector<Index> path_position; // per supernode: its index in the group's path, or -1
    };
    // A group's Y = L^-1 P B, kept for the groups that borrow its columns: its rows are those of
    // the supernodes on its path (ascending), each supernode's consecutive from offset[i] on.
    struct SolvedGroup
    {
      std::vector<Index>  path, offset;
      int                 ld = 1;
      std::vector<double> Y; // ld x |B|, column-major
    };
    // One group of group_grams: G = B^T A^-1 B[:, 0 .. leading), and its Y in 'solved' when given.
    // X is local: the rows of the group's path, in the order of its supernodes.
    std::vector<double> group_gram(const std::vector<SparseColumn> &B, std::size_t leading,
                                   const std::vector<Index> &position_of_row, GroupScratch &scratch,
                                   SolvedGroup *solved) const;
    // The bytes the groups' Y would take (their paths' rows times their widths).
    double solved_groups_bytes(const std::vector<GramGroup> &groups, const std::vector<Index> &position_of_row) const;
    // G's borrowed rows of a group (own: its Y; gram: |B| + |C| rows) from the lending groups' Y.
    void add_borrowed_rows(const GramGroup &group, const SolvedGroup &own, const std::vector<SolvedGroup> &solved,
                           std::vector<double> &gram) const;
    // Per supernode of the group's path, the columns of B whose own path it is on:
    // a column's solution is zero on every other supernode of the union. Ascending.
    std::vector<std::vector<int>> active_columns(const std::vector<SparseColumn> &B, const std::vector<Index> &path,
                                                 const std::vector<Index> &position_of_row, GroupScratch &scratch) const;
    // The Gram matrix of a group (width x n_leading, column-major) as its supernodes add to it.
    struct GroupGram
    {
      std::vector<double> G;
      int                 width, n_leading;
      std::vector<double> part; // one supernode's share, before it is scattered into G
    };
    // One supernode of L y = b in the local X (ld rows per column), for the columns 'active' only
    // (n_active of them, all when n_active is X's width): y at its own rows, its updates to the rows
    // below subtracted, and y's own rows' share of Y^T Y added to 'gram' (the rows of a supernode are
    // final once it is solved). 'own' holds the active columns' own rows while they are solved.
    void forward_local(Index supernode, double *X, int ld, const Index *local_row, const int *active, int n_active,
                       double *own, double *workspace, GroupGram &gram) const;
    // gram.G += Y_s^T Y_s for the supernode's own rows Y_s (n_rows x n_active at 'rows', ld apart):
    // a column of Y is zero off its own path, so only the columns active here meet on these rows.
    void add_to_gram(const double *rows, int n_rows, int ld, const int *active, int n_active, GroupGram &gram) const;
    // y_own = L11^-1 y_own in place (at 'own', ld rows per column) and workspace = L21 y_own (below
    // x n_rhs): what the supernode subtracts from the rows below it; false when it has none.
    bool solve_own_rows(const Block &b, double *own, int ld, int n_rhs, double *workspace) const;
    // One supernode of L y = b: y at its own rows, its updates to the rows below subtracted from
    // X, or from 'top_updates' for the rows of the top (when given; laid out as X, n_top_columns rows).
    void forward(Index supernode, double *X, int n_rhs, double *workspace, double *top_updates) const;
    // One supernode of L^T x = y (reads x at the rows below it, solved before).
    void backward(Index supernode, double *X, int n_rhs, double *workspace) const;
    // forward and backward for 'width' right-hand sides in a row-interleaved X (X[row * width +
    // c]), by the narrow kernels, on the supernode's rows gathered in rows_of_block (max_rows rows).
    template <int width>
    void forward_narrow(Index supernode, double *X, double *rows_of_block, double *top_updates) const;
    template <int width>
    void backward_narrow(Index supernode, double *X, double *rows_of_block) const;
    template <int width>
    void solve_narrow(double *columns) const;
    template <typename Forward, typename Backward>
    void solve_in_tree_order(double *columns, unsigned int n_rhs, bool interleaved, const Forward &forward_step,
                             const Backward &backward_step) const;

    Index                      n, n_supernodes, max_rows_below, max_rows = 0;
    const Index               *first_column, *row_start, *value_start, *rows, *permutation;
    const double              *values;
    std::vector<Index>         supernode_of_column, parent_supernode; // the tree (-1 at a root)
    std::vector<std::vector<Index>> subtrees_of_thread; // their supernodes, ascending
    std::vector<Index>         top_supernodes;          // ascending
    std::vector<Index>         top_position;            // per column: its index among the top's columns, or -1
    Index                      n_top_columns = 0;
    double                     top_entries = 0., total_entries = 0., largest_thread_entries = 0.;
  };
} // namespace modal_haptics
