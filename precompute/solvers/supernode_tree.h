// The elimination tree of a CHOLMOD supernodal factor's supernodes, and its split into independent
// subtrees for parallel threads: what the triangular solves (supernodal_solve.h) and the numeric
// factorization (supernodal_cholesky.h) share. A supernode depends only on the supernodes below it,
// so the subtrees below a "top" of the tree run on their threads at once, and the top after them.
#pragma once

#include <cholmod.h>

#include <functional>
#include <vector>

namespace modal_haptics
{
  using SupernodeIndex = SuiteSparse_long;

  struct SupernodeTree
  {
    std::vector<SupernodeIndex>              supernode_of_column;
    std::vector<SupernodeIndex>              parent; // -1 at a root
    std::vector<std::vector<SupernodeIndex>> children;
    std::vector<SupernodeIndex>              roots; // ascending
  };

  // The tree of a supernodal factor (analysed or numeric): a supernode's parent holds its first row
  // below its own columns. A parent comes after its children (CHOLMOD's postorder).
  SupernodeTree supernode_tree(const cholmod_factor &factor);

  // Where each supernode runs, and what the split costs in the weights it was made for.
  struct TreeSplit
  {
    std::vector<std::vector<SupernodeIndex>> subtrees_of_thread; // their supernodes, ascending
    std::vector<SupernodeIndex>              top;                // after the subtrees, ascending
    double top_weight = 0., largest_thread_weight = 0., total_weight = 0.;
  };

  // Splits the tree for 'threads' threads by the supernodes' weights (what each costs the work at
  // hand: entries of L for a solve, flops for the factorization). The subtrees of the roots are
  // packed onto the threads (largest first, each onto the least loaded thread); then, again and
  // again, the heaviest subtree is cut off its root, which joins the top (run by one thread after
  // the subtrees), and its children's subtrees are packed instead. The work then costs about the
  // top + the most loaded thread: the cut that minimizes it is kept. threads >= 1.
  TreeSplit split_tree(const SupernodeTree &tree, const std::vector<double> &weight, unsigned int threads);

  // Runs work(t) for t = 0 .. threads - 1, t = 0 on the calling thread. If a thread cannot be
  // started, the ones running are joined before the error goes on.
  void run_on_threads(unsigned int threads, const std::function<void(unsigned int)> &work);
} // namespace modal_haptics
