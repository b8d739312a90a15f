// Triangular solves with a CHOLMOD supernodal Cholesky factor (P A P^T = L L^T), with independent
// subtrees of the elimination tree on parallel threads.
//
// Why not cholmod_solve: it walks the supernodes one after the other, and per supernode runs a small
// TRSM/GEMM on a few right-hand sides whose latency, not the memory, bounds it (250k DoFs: a
// 4-column solve reads the 1.34 GB factor twice in 0.33 s, 8 GB/s of the 27 one thread can read).
// Splitting the columns between two threads makes each of them read the whole factor (0.27-0.29
// s). Here every thread takes its own subtrees, so the factor is read once for all the columns;
// only the separators above the subtrees (the top of the tree, ~8 % of the factor on the FACTS
// plate) are solved by one thread (0.18-0.19 s for the same solve; docs/performance.md).
#pragma once

#include <cholmod.h>

#include <vector>

namespace modal_haptics
{
  class SupernodalSolve
  {
  public:
    // factor: a supernodal L L^T factor (CHOLMOD's is_super and is_ll), kept by the caller and
    // only read from here on; threads >= 1 (1: the whole tree in order on the calling thread).
    SupernodalSolve(const cholmod_factor &factor, unsigned int threads);

    // Solves A X = B in place for n_rhs columns of length n, one after the other (column-major).
    void solve(double *columns, unsigned int n_rhs) const;

    unsigned int n_threads() const { return subtrees_of_thread.size(); }

    // The shares of the factor's entries in the top of the tree (solved by one thread) and in the
    // most loaded thread's subtrees.
    double top_share() const { return top_entries / total_entries; }
    double largest_thread_share() const { return largest_thread_entries / total_entries; }

  private:
    using Index = SuiteSparse_long;
    struct Block;

    void assign_subtrees(unsigned int threads);
    // One supernode of L y = b: y at its own rows, its updates to the rows below subtracted from
    // X, or added to 'top_updates' for the rows of the top (when given).
    void forward(Index supernode, double *X, int n_rhs, double *workspace, double *top_updates) const;
    // One supernode of L^T x = y (reads x at the rows below it, solved before).
    void backward(Index supernode, double *X, int n_rhs, double *workspace) const;

    Index                      n, n_supernodes, max_rows_below;
    const Index               *first_column, *row_start, *value_start, *rows, *permutation;
    const double              *values;
    std::vector<std::vector<Index>> subtrees_of_thread; // their supernodes, ascending
    std::vector<Index>         top_supernodes;          // ascending
    std::vector<Index>         top_position;            // per column: its index among the top's columns, or -1
    Index                      n_top_columns = 0;
    double                     top_entries = 0., total_entries = 0., largest_thread_entries = 0.;
  };
} // namespace modal_haptics
