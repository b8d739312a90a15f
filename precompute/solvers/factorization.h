// Sparse direct factorizations of A = K - sigma M behind the shift-invert eigensolve, the static
// correction and the validation solves: factor once, solve many (blocks of right-hand sides).
#pragma once

#include "solvers/blas_lapack.h"
#include "solvers/solver_statistics.h"
#include "solvers/supernodal_solve.h"

#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <mpi.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace modal_haptics
{
  // The mesh's nodes among a matrix's rows: runs of consecutive rows with the same sparsity pattern
  // (a node's three displacement components, which deal.II numbers together). sorted_row(i) gives
  // row i's columns in increasing order. Returns each node's first row, then n_rows.
  template <typename SortedRow>
  std::vector<std::size_t> node_first_rows(const std::size_t n_rows, const SortedRow &sorted_row)
  {
    std::vector<std::size_t> first_rows;
    decltype(sorted_row(0))  previous;
    for (std::size_t row = 0; row < n_rows; ++row)
      {
        auto columns = sorted_row(row);
        if (first_rows.empty() || columns != previous)
          first_rows.push_back(row);
        previous.swap(columns);
      }
    first_rows.push_back(n_rows);
    return first_rows;
  }

  // A graph of mesh nodes, node by node: how many neighbours each has (nodes it shares a matrix
  // entry with, itself left out), the neighbours one node after the other, and each node's rows.
  struct NodeGraph
  {
    std::vector<int> degrees, neighbours, weights;
  };

  // The graph of the nodes that first_rows delimits (node_first_rows, its last entry the end):
  // node_of(column) numbers the node that holds a column, and the g-th node here is number
  // first_node + g. The columns come sorted, so a node's rows come one after the other and each
  // neighbour is listed once.
  template <typename SortedRow, typename NodeOf>
  NodeGraph node_graph(const std::vector<std::size_t> &first_rows, const SortedRow &sorted_row, const NodeOf &node_of,
                       const int first_node)
  {
    NodeGraph graph;
    for (std::size_t g = 0; g + 1 < first_rows.size(); ++g)
      {
        graph.weights.push_back(int(first_rows[g + 1] - first_rows[g]));
        const std::size_t before = graph.neighbours.size();
        for (const auto column : sorted_row(first_rows[g]))
          if (const int node = node_of(column);
              node != first_node + int(g) && (graph.neighbours.size() == before || graph.neighbours.back() != node))
            graph.neighbours.push_back(node);
        graph.degrees.push_back(int(graph.neighbours.size() - before));
      }
    return graph;
  }

  // A fill-reducing ordering of the nodes: METIS's nested dissection of their graph, on the node
  // graph rather than the rows' because it has a third of the vertices and a ninth of the edges
  // (METIS runs several times faster) and a separator never cuts a node's components apart.
  // Returns the nodes in pivot order. The serial (CHOLMOD) and the distributed (MUMPS)
  // factorizations use it.
  std::vector<int> nested_dissection_of_nodes(NodeGraph &graph);

  // What OpenBLAS reads from the environment when it loads, before main, and what this program sets
  // there unless the user has set it, as the first line of main, before anything else has happened:
  // - OPENBLAS_THREAD_TIMEOUT = 20. OpenBLAS's idle worker threads spin for 2^28 cycles (about 0.1 s)
  //   after every call before they sleep; on 2 cores the spinning worker takes a core from our own
  //   threads (the triangular solves start right after the eigensolver's GEMMs on the basis;
  //   docs/performance.md, "OpenBLAS's idle workers spin briefly"). The running OpenBLAS reads it again
  //   and restarts its workers. Not under an MPI launcher: there each process has one BLAS thread
  //   (no idle worker to spin).
  // - OPENBLAS_CORETYPE, only where OpenBLAS did not know the CPU and fell back to its generic
  //   Prescott kernels (blas_kernels_for_this_cpu): under an MPI launcher too, since every process
  //   runs the BLAS's slow kernels otherwise. Chosen when the library loads: the program restarts
  //   itself for it (execv of itself, same PID, same arguments).
  void apply_openblas_settings(char **argv);

  // The kernels the running OpenBLAS uses ("SkylakeX", "Haswell", "Zen", ...; empty when the BLAS
  // is not OpenBLAS), and whether this program chose them (OPENBLAS_CORETYPE set by
  // apply_openblas_settings), and the idle workers' spin OpenBLAS runs with (OPENBLAS_THREAD_TIMEOUT
  // as it read it: 2^spin_exponent cycles; 0: its default, 2^28).
  struct BlasKernels
  {
    std::string core;
    bool        chosen_by_us  = false;
    int         spin_exponent = 0;
  };
  BlasKernels running_blas_kernels();

  class Factorization
  {
  public:
    virtual ~Factorization() = default;

    // Solves A X = B in place for n_rhs columns stored one after the other (column-major, each of
    // length n). A block is much cheaper per column than single solves: the factor is read once.
    virtual void solve_block(double *columns, unsigned int n_rhs) = 0;

    // The Gram matrices G_g = [B_g C_g]^T A^-1 B_g of groups of sparse columns with the columns
    // they borrow from other groups (column-major; SupernodalSolve::group_grams), when the
    // factorization gives them without a full solve per column (CHOLMOD's); false otherwise, and
    // the caller solves.
    virtual bool group_grams(const std::vector<GramGroup> & /*groups*/, std::vector<std::vector<double>> & /*grams*/)
    {
      return false;
    }

    // The shift-invert operator for ARPACK: dst = A^{-1} src.
    void vmult(dealii::Vector<double> &dst, const dealii::Vector<double> &src);

    const FactorizationStatistics &statistics() const { return stats; }

  protected:
    FactorizationStatistics stats;
  };

  // A fill-reducing ordering of a matrix's rows as CHOLMOD takes it (permutation[k]: the row that
  // comes k-th) and the seconds it took.
  struct FillOrdering
  {
    std::vector<SuiteSparse_long> permutation;
    double                        seconds = 0.;
  };
  // The ordering make_cholmod_factorization computes for a matrix of this sparsity pattern (METIS's
  // nested dissection of the node graph). It needs the pattern only, so a space computes it on a
  // thread of its own while it assembles K and M, and hands it over.
  FillOrdering cholmod_fill_ordering(const dealii::SparsityPattern &pattern);

  // Factorizes K - shift M (shift in rad^2/s^2; M may be null when shift = 0). Throws ExcMessage
  // when the matrix is not positive definite (a shift above the first eigenvalue, a part that is
  // not clamped), naming what to change. ordering: cholmod_fill_ordering of K's pattern, or empty
  // (then computed here).
  std::unique_ptr<Factorization> make_cholmod_factorization(const dealii::SparseMatrix<double> &K,
                                                            const dealii::SparseMatrix<double> *M,
                                                            double shift, FillOrdering ordering = {});
  // The same, only when the analysis predicts a factor of at most memory_limit bytes; otherwise
  // nullptr, without factorizing (predicted_factor_bytes says what it would have taken).
  std::unique_ptr<Factorization> make_cholmod_factorization_within(const dealii::SparseMatrix<double> &K,
                                                                   const dealii::SparseMatrix<double> *M,
                                                                   double shift, double memory_limit,
                                                                   double &predicted_factor_bytes,
                                                                   FillOrdering ordering = {});

  // MemAvailable of /proc/meminfo (infinity where there is none).
  double available_memory_bytes();

  // 'Modes/Factor memory limit' in bytes (limit_gb in GB), or half the memory available now when it is 0.
  double memory_budget_bytes(double limit_gb);

  // The MPI processes of comm that share this one's node (and its memory).
  unsigned int processes_on_this_node(MPI_Comm comm);

  // This process's share of its node's memory_budget_bytes(limit_gb), the smallest over comm's
  // processes so that all decide alike.
  double memory_budget_per_process_bytes(double limit_gb, MPI_Comm comm);

  std::unique_ptr<Factorization> make_umfpack_factorization(const dealii::SparseMatrix<double> &K,
                                                            const dealii::SparseMatrix<double> *M,
                                                            double shift);
} // namespace modal_haptics
