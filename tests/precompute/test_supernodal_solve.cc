// SupernodalSolve (precompute/supernodal_solve.h) against cholmod_solve on the same factor: every
// thread count splits the elimination tree differently (1 to 7 threads, more than the machine has
// is fine: they only run slower), every answer must be CHOLMOD's to rounding. Matrices: a
// plate-like vector Laplacian (a tree with deep, wide subtrees, like the parts' stiffness), a
// diagonal matrix (a forest of single supernodes), a tridiagonal one (METIS makes its path a
// balanced tree; in the natural order it is a chain, with no parallelism to find) and a 1 x 1
// matrix; a simplicial factor is refused. group_grams ([B_g C_g]^T A^-1 B_g of groups of sparse
// columns by forward solves on their elimination-tree paths, C_g borrowed from the other groups)
// against B^T of the full solve, for columns of one to six nonzeros scattered or clustered, an empty
// column, groups of one column to all of them (each supernode solving only the columns whose path
// it is on), every third column of the other groups borrowed, their solves kept or (a storage
// limit of 0) solved again in the borrowing group, every thread count.
// factorize_supernodal (precompute/supernodal_cholesky.h) against cholmod_l_factorize on the same
// analysis, for the same matrices and thread counts: the factor CHOLMOD's to rounding, the same bit
// for bit when factorized again on as many threads, the first column that is not
// positive definite CHOLMOD's (matrices shifted past their lowest eigenvalue), an entry off the
// analysed pattern and a simplicial analysis refused.
#include "solvers/supernodal_cholesky.h"
#include "solvers/supernodal_solve.h"

#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
  using Index = SuiteSparse_long;
  int failures = 0;

  void check(const bool ok, const std::string &what)
  {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
    failures += !ok;
  }

  using Column = std::function<std::vector<std::pair<Index, double>>(Index)>;

  // A symmetric matrix as CHOLMOD's stype 1: column(j) lists (row, value) in ascending rows; the
  // rows i <= j are kept (the upper triangle CHOLMOD reads), or all of them with both_triangles
  // (what factorize_supernodal reads).
  cholmod_sparse *symmetric_matrix(const Index n, const Column &column, cholmod_common &common,
                                   const bool both_triangles = false)
  {
    std::vector<Index>  start{0}, row;
    std::vector<double> value;
    for (Index j = 0; j < n; ++j)
      {
        for (const auto &[i, v] : column(j))
          if (both_triangles || i <= j)
            {
              row.push_back(i);
              value.push_back(v);
            }
        start.push_back(row.size());
      }
    cholmod_sparse *A = cholmod_l_allocate_sparse(n, n, row.size(), 0, 1, 1, CHOLMOD_REAL, &common);
    std::copy(start.begin(), start.end(), static_cast<Index *>(A->p));
    std::copy(row.begin(), row.end(), static_cast<Index *>(A->i));
    std::copy(value.begin(), value.end(), static_cast<double *>(A->x));
    return A;
  }

  // A plate-like grid of nx x ny x nz points, 3 unknowns per point:
  // (7-point Laplacian) x [[2,1,0],[1,2,1],[0,1,2]] + (1 - shift) I (SPD for shift < 1).
  cholmod_sparse *vector_laplacian(const Index nx, const Index ny, const Index nz, cholmod_common &common,
                                   const bool both_triangles = false, const double shift = 0.)
  {
    const Index points = nx * ny * nz;
    return symmetric_matrix(3 * points, [&](const Index j) {
      const Index p = j / 3, a = j % 3, x = p % nx, y = (p / nx) % ny, z = p / (nx * ny);
      std::vector<std::pair<Index, double>> entries;
      const auto coupling = [](const Index a, const Index b) { return a == b ? 2. : (std::abs(a - b) == 1 ? 1. : 0.); };
      const auto add_point = [&](const Index q, const double laplacian) {
        for (Index b = 0; b < 3; ++b)
          if (coupling(a, b) != 0.)
            entries.emplace_back(3 * q + b, laplacian * coupling(a, b) + (q == p && a == b ? 1. - shift : 0.));
      };
      add_point(p, 6.);
      const Index step[3] = {1, nx, nx * ny}, coordinate[3] = {x, y, z}, size[3] = {nx, ny, nz};
      for (int d = 0; d < 3; ++d)
        {
          if (coordinate[d] > 0)
            add_point(p - step[d], -1.);
          if (coordinate[d] + 1 < size[d])
            add_point(p + step[d], -1.);
        }
      std::sort(entries.begin(), entries.end());
      return entries;
    }, common, both_triangles);
  }

  cholmod_factor *factorize(cholmod_sparse *A, cholmod_common &common, const int supernodal,
                            const int ordering = CHOLMOD_METIS)
  {
    common.nmethods           = 1;
    common.method[0].ordering = ordering;
    common.supernodal         = supernodal;
    cholmod_factor *L         = cholmod_l_analyze(A, &common);
    cholmod_l_factorize(A, L, &common);
    if (common.status != CHOLMOD_OK)
      throw std::runtime_error("CHOLMOD failed on a test matrix");
    return L;
  }

  // Every thread count and a few block widths: max |ours - CHOLMOD| / max |CHOLMOD|. With
  // 'parallel', the split must also promise a gain from 2 threads on: the top plus the most loaded
  // thread at most 3/4 of the factor.
  void compare_with_cholmod(const std::string &name, cholmod_sparse *A, cholmod_common &common, const bool parallel,
                            const int ordering = CHOLMOD_METIS)
  {
    cholmod_factor *L = factorize(A, common, CHOLMOD_SUPERNODAL, ordering);
    const Index     n = L->n;
    for (const unsigned int n_rhs : {1u, 2u, 3u, 4u, 13u})
      {
        cholmod_dense *B = cholmod_l_allocate_dense(n, n_rhs, n, CHOLMOD_REAL, &common);
        auto          *b = static_cast<double *>(B->x);
        for (Index i = 0; i < n * Index(n_rhs); ++i)
          b[i] = std::sin(0.37 * double(i) + 1.);
        cholmod_dense *X    = cholmod_l_solve(CHOLMOD_A, L, B, &common);
        const auto    *x    = static_cast<const double *>(X->x);
        const double   xmax = std::abs(*std::max_element(x, x + n * n_rhs, [](double p, double q) { return std::abs(p) < std::abs(q); }));
        for (const unsigned int threads : {1u, 2u, 3u, 4u, 7u})
          {
            const modal_haptics::SupernodalSolve solver(*L, threads);
            std::vector<double> ours(b, b + n * n_rhs);
            solver.solve(ours.data(), n_rhs);
            double difference = 0.;
            for (Index i = 0; i < n * Index(n_rhs); ++i)
              difference = std::max(difference, std::abs(ours[i] - x[i]));
            const double predicted = solver.top_share() + solver.largest_thread_share();
            char         line[240];
            std::snprintf(line, sizeof line,
                          "%s, n = %ld, %u right-hand sides, %u threads (top %.1f %% of L, largest thread %.1f %%): %.1e of max |x|",
                          name.c_str(), long(n), n_rhs, threads, 100. * solver.top_share(),
                          100. * solver.largest_thread_share(), difference / xmax);
            check(difference <= 1e-12 * xmax && (!parallel || threads == 1 || predicted <= 0.75), line);
          }
        cholmod_l_free_dense(&X, &common);
        cholmod_l_free_dense(&B, &common);
      }
    cholmod_l_free_factor(&L, &common);
  }
  // Sparse columns: column k has 1 + k % 6 nonzeros, on rows spread over the matrix or (cluster)
  // within a window of rows, like a contact patch's DoFs; the last column is empty.
  std::vector<modal_haptics::SparseColumn> sparse_columns(const Index n, const std::size_t m, const bool cluster)
  {
    std::vector<modal_haptics::SparseColumn> B(m);
    for (std::size_t k = 0; k + 1 < m; ++k)
      for (std::size_t e = 0; e <= k % 6; ++e)
        {
          const Index window = cluster ? std::min<Index>(n, 60) : n;
          const Index base   = cluster ? Index((k * 7919) % std::size_t(n - window + 1)) : 0;
          B[k].emplace_back(std::size_t(base + Index((k * 131 + e * 977) % std::size_t(window))),
                            std::cos(0.3 * double(k) + double(e)));
        }
    return B;
  }

  void check_group_grams(const std::string &name, cholmod_sparse *A, cholmod_common &common)
  {
    cholmod_factor *L = factorize(A, common, CHOLMOD_SUPERNODAL);
    const Index     n = L->n;
    for (const bool cluster : {false, true})
      for (const std::size_t m : {std::size_t(1), std::size_t(7), std::size_t(150)})
        {
          const auto          B = sparse_columns(n, m, cluster);
          std::vector<double> dense(std::size_t(n) * m, 0.);
          for (std::size_t k = 0; k < m; ++k)
            for (const auto &[row, value] : B[k])
              dense[row + k * n] += value;
          const modal_haptics::SupernodalSolve reference(*L, 1);
          std::vector<double>                  X = dense;
          reference.solve(X.data(), m);
          std::vector<double> expected(m * m, 0.); // B^T A^-1 B
          double              largest = 0.;
          for (std::size_t j = 0; j < m; ++j)
            for (std::size_t i = 0; i < m; ++i)
              {
                for (Index r = 0; r < n; ++r)
                  expected[i + j * m] += dense[r + i * n] * X[r + j * n];
                largest = std::max(largest, std::abs(expected[i + j * m]));
              }
          // Groups of 'size' consecutive columns (the last one shorter), each borrowing every
          // third column of the other groups; their products kept (no limit) or solved again (0).
          for (const std::size_t size : {std::size_t(1), std::size_t(5), m})
            for (const unsigned int threads : {1u, 2u, 3u})
              for (const double storage_limit : {std::numeric_limits<double>::infinity(), 0.})
                {
                  std::vector<modal_haptics::GramGroup> groups;
                  std::vector<std::size_t>              first;
                  for (std::size_t start = 0; start < m; start += size)
                    {
                      groups.push_back({{B.begin() + start, B.begin() + std::min(m, start + size)}, {}, {}});
                      first.push_back(start);
                    }
                  // Each borrowed column wanted with every second own column from its position on.
                  for (std::size_t g = 0; g < groups.size(); ++g)
                    for (std::size_t h = 0; h < groups.size(); ++h)
                      for (std::size_t c = 0; c < groups[h].columns.size() && h != g; c += 3)
                        {
                          groups[g].borrowed.emplace_back(h, c);
                          groups[g].wanted.emplace_back();
                          for (std::size_t j = groups[g].borrowed.size() % 2; j < groups[g].columns.size(); j += 2)
                            groups[g].wanted.back().push_back(j);
                        }
                  const auto grams = modal_haptics::SupernodalSolve(*L, threads).group_grams(groups, storage_limit);
                  double     difference = grams.size() == groups.size() ? 0. : 1.;
                  for (std::size_t g = 0; g < grams.size(); ++g)
                    {
                      const std::size_t width = groups[g].columns.size(), rows = width + groups[g].borrowed.size();
                      // G's row i: column first[g] + i of B, or the borrowed column's.
                      const auto column_of_row = [&](const std::size_t i) {
                        if (i < width)
                          return first[g] + i;
                        const auto [h, c] = groups[g].borrowed[i - width];
                        return first[h] + c;
                      };
                      if (grams[g].size() != rows * width)
                        difference = 1.;
                      else
                        for (std::size_t j = 0; j < width; ++j)
                          for (std::size_t i = 0; i < rows; ++i)
                            if (i < width || std::binary_search(groups[g].wanted[i - width].begin(),
                                                                groups[g].wanted[i - width].end(), j))
                              difference = std::max(difference, std::abs(grams[g][i + j * rows] -
                                                                         expected[column_of_row(i) + (first[g] + j) * m]));
                    }
                  char line[260];
                  std::snprintf(line, sizeof line,
                                "group_grams, %s, %s columns, m = %zu in groups of %zu, %u threads, borrowed columns %s: %.1e of max |G|",
                                name.c_str(), cluster ? "clustered" : "scattered", m, size, threads,
                                storage_limit > 0. ? "kept" : "solved again", difference / std::max(largest, 1e-300));
                  check(difference <= 1e-12 * std::max(largest, 1e-300), line);
                }
        }
    cholmod_l_free_factor(&L, &common);
  }
  // factorize_supernodal against cholmod_l_factorize on one analysis of A (both triangles stored:
  // CHOLMOD reads the upper one), for 1 to 7 threads: the factor to rounding of CHOLMOD's and the
  // same bit for bit when factorized again (the split of the tree, and with it the order of some
  // sums, depends on the number of threads, not on their timing), or, for a matrix that is not
  // positive definite, the same first failing column.
  void check_factorization(const std::string &name, cholmod_sparse *A, cholmod_common &common,
                           const int ordering = CHOLMOD_METIS)
  {
    common.nmethods           = 1;
    common.method[0].ordering = ordering;
    common.supernodal         = CHOLMOD_SUPERNODAL;
    cholmod_factor *symbolic  = cholmod_l_analyze(A, &common);
    cholmod_factor *reference = cholmod_l_copy_factor(symbolic, &common);
    const int       print     = common.print;
    common.print              = 0; // CHOLMOD's warning for the matrices that are not positive definite
    cholmod_l_factorize(A, reference, &common);
    common.print = print;
    const bool    positive_definite = reference->minor == reference->n;
    const auto   *expected          = static_cast<const double *>(reference->x);
    const Index   size              = Index(reference->xsize);
    const double  largest = positive_definite ? std::abs(*std::max_element(expected, expected + size, [](double p, double q) {
                                                  return std::abs(p) < std::abs(q);
                                                }))
                                              : 1.;
    for (const unsigned int threads : {1u, 2u, 3u, 4u, 7u})
      {
        cholmod_factor *L     = cholmod_l_copy_factor(symbolic, &common);
        const Index     minor = modal_haptics::factorize_supernodal(*A, *L, common, threads);
        const auto     *x     = static_cast<const double *>(L->x);
        char            line[240];
        if (positive_definite)
          {
            double difference = 0.;
            for (Index i = 0; i < size; ++i)
              difference = std::max(difference, std::abs(x[i] - expected[i]));
            cholmod_factor *again = cholmod_l_copy_factor(symbolic, &common);
            modal_haptics::factorize_supernodal(*A, *again, common, threads);
            const bool same_again = std::equal(x, x + size, static_cast<const double *>(again->x));
            cholmod_l_free_factor(&again, &common);
            std::snprintf(line, sizeof line, "factorization, %s, n = %ld, %u threads: %.1e of max |L|%s", name.c_str(),
                          long(L->n), threads, difference / largest, same_again ? "" : ", NOT the same when factorized again");
            check(minor == Index(L->n) && L->is_ll && L->minor == L->n && difference <= 1e-12 * largest && same_again,
                  line);
          }
        else
          {
            std::snprintf(line, sizeof line, "factorization, %s, n = %ld, %u threads: not positive definite at column %ld (CHOLMOD: %ld)",
                          name.c_str(), long(L->n), threads, long(minor), long(reference->minor));
            check(minor == Index(reference->minor) && L->minor == reference->minor, line);
          }
        cholmod_l_free_factor(&L, &common);
      }
    cholmod_l_free_factor(&reference, &common);
    cholmod_l_free_factor(&symbolic, &common);
  }

  // factorize_supernodal refuses what it cannot factor: an entry whose mirror the analysis of the
  // upper triangle did not see, and a simplicial analysis.
  void check_factorization_refusals(cholmod_common &common)
  {
    // A diagonal matrix with one entry below the diagonal (5, 2) and none above: each supernode
    // holds one row, so the entry falls outside the pattern wherever the ordering puts it.
    cholmod_sparse *lopsided = symmetric_matrix(10, [](const Index j) {
      std::vector<std::pair<Index, double>> entries{{j, 4.}};
      if (j == 2)
        entries.emplace_back(5, 1.);
      return entries;
    }, common, true);
    common.supernodal      = CHOLMOD_SUPERNODAL;
    cholmod_factor *L      = cholmod_l_analyze(lopsided, &common);
    std::string     message;
    try
      {
        modal_haptics::factorize_supernodal(*lopsided, *L, common, 2);
      }
    catch (const std::runtime_error &error)
      {
        message = error.what();
      }
    check(message.find("outside the pattern") != std::string::npos, "an entry off the analysed pattern is refused: " + message);
    cholmod_l_free_factor(&L, &common);

    common.supernodal = CHOLMOD_SIMPLICIAL;
    L                 = cholmod_l_analyze(lopsided, &common);
    bool refused      = false;
    try
      {
        modal_haptics::factorize_supernodal(*lopsided, *L, common, 2);
      }
    catch (const std::invalid_argument &)
      {
        refused = true;
      }
    check(refused, "a simplicial analysis is refused by the factorization");
    cholmod_l_free_factor(&L, &common);
    cholmod_l_free_sparse(&lopsided, &common);
  }
} // namespace

int main()
{
  cholmod_common common;
  cholmod_l_start(&common);

  cholmod_sparse *laplacian = vector_laplacian(48, 24, 6, common);
  compare_with_cholmod("plate-like vector Laplacian", laplacian, common, true);

  check_group_grams("plate-like vector Laplacian", laplacian, common);

  const Column diagonal_column = [](Index j) { return std::vector<std::pair<Index, double>>{{j, 1. + j % 7}}; };
  cholmod_sparse *diagonal     = symmetric_matrix(1000, diagonal_column, common);
  compare_with_cholmod("diagonal", diagonal, common, true);

  const Index  chain_length = 5000;
  const Column chain_column = [&](Index j) {
    std::vector<std::pair<Index, double>> entries;
    if (j > 0)
      entries.emplace_back(j - 1, -1.);
    entries.emplace_back(j, 2.5);
    if (j + 1 < chain_length)
      entries.emplace_back(j + 1, -1.);
    return entries;
  };
  cholmod_sparse *chain = symmetric_matrix(chain_length, chain_column, common);
  compare_with_cholmod("tridiagonal", chain, common, true);
  compare_with_cholmod("tridiagonal in the natural order", chain, common, false, CHOLMOD_NATURAL);
  check_group_grams("tridiagonal", chain, common);

  const Column    one_column = [](Index) { return std::vector<std::pair<Index, double>>{{0, 4.}}; };
  cholmod_sparse *one        = symmetric_matrix(1, one_column, common);
  compare_with_cholmod("1 x 1", one, common, false);

  cholmod_factor *simplicial = factorize(laplacian, common, CHOLMOD_SIMPLICIAL);
  bool refused = false;
  try
    {
      modal_haptics::SupernodalSolve solver(*simplicial, 2);
    }
  catch (const std::invalid_argument &)
    {
      refused = true;
    }
  check(refused, "a simplicial factor is refused");
  cholmod_l_free_factor(&simplicial, &common);

  // The factorization reads both triangles. A shift of 1.5 puts the vector Laplacian's lowest
  // eigenvalues (about 1 + 4 (1 - cos(pi / 49)) ... ) below zero; the diagonal matrix with one
  // negative entry fails at that entry's column, wherever the ordering puts it.
  std::vector<cholmod_sparse *> both_triangles{
    vector_laplacian(48, 24, 6, common, true), symmetric_matrix(1000, diagonal_column, common, true),
    symmetric_matrix(chain_length, chain_column, common, true), symmetric_matrix(1, one_column, common, true),
    vector_laplacian(48, 24, 6, common, true, 1.5), symmetric_matrix(1000, [](Index j) {
      return std::vector<std::pair<Index, double>>{{j, j == 617 ? -1. : 1. + j % 7}};
    }, common, true)};
  check_factorization("plate-like vector Laplacian", both_triangles[0], common);
  check_factorization("diagonal", both_triangles[1], common);
  check_factorization("tridiagonal", both_triangles[2], common);
  check_factorization("tridiagonal in the natural order", both_triangles[2], common, CHOLMOD_NATURAL);
  check_factorization("1 x 1", both_triangles[3], common);
  check_factorization("vector Laplacian shifted past its lowest eigenvalue", both_triangles[4], common);
  check_factorization("diagonal with a negative entry", both_triangles[5], common);
  check_factorization_refusals(common);

  for (cholmod_sparse *A : {laplacian, diagonal, chain, one})
    cholmod_l_free_sparse(&A, &common);
  for (cholmod_sparse *A : both_triangles)
    cholmod_l_free_sparse(&A, &common);
  cholmod_l_finish(&common);
  std::printf("%d failure(s)\n", failures);
  return failures == 0 ? 0 : 1;
}
