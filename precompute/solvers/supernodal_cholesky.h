// The numeric supernodal Cholesky factorization P A P^T = L L^T, into the factor CHOLMOD's analysis
// laid out (cholmod_l_analyze_p with CHOLMOD_SUPERNODAL), with independent subtrees of the
// elimination tree on parallel threads.
//
// Why not cholmod_l_factorize: it runs the supernodes one after the other and leaves the
// parallelism to the BLAS, whose calls on the many small supernodes below the top of the tree are
// too small to share (bench-factorization against it: docs/performance.md). The method is CHOLMOD's
// left-looking one: a supernode gathers its columns of P A P^T, subtracts the updates of the
// supernodes below it whose rows reach its columns (SYRK and GEMM, scattered), then POTRF on its
// diagonal block and TRSM below it. A supernode only reads supernodes of its own subtree, so each
// thread takes whole subtrees (one BLAS thread each) and the top, which every subtree updates, comes
// after them on every BLAS thread (the split: supernode_tree.h, weighed by the flops). Each supernode
// sums its updates in one order, the supernodes below it ascending: the factor is the same bit for
// bit from run to run on as many threads (the split, and with it which supernodes run on one BLAS
// thread, depends on their number).
#pragma once

#include "solvers/supernode_tree.h"

#include <cholmod.h>

namespace modal_haptics
{
  // Factorizes A into 'factor', an analysed (symbolic) supernodal factor of A's pattern, which
  // becomes numeric (is_ll; common: the CHOLMOD workspace it was analysed with). A: real, packed,
  // with both triangles stored (a symmetric pattern, as deal.II's matrices have) and stype 1, so
  // that CHOLMOD's analysis reads its upper one; column k of P A P^T is gathered from column
  // Perm[k] of A. threads >= 1. Returns the first column (in the factor's order) where P A P^T is
  // not positive definite, as cholmod_l_factorize would (factor.minor too), or n when it is.
  // Throws std::runtime_error when the factor's memory cannot be had or A does not fit the factor.
  SupernodeIndex factorize_supernodal(const cholmod_sparse &A, cholmod_factor &factor, cholmod_common &common,
                                      unsigned int threads);
} // namespace modal_haptics
