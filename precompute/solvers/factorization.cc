#include "solvers/factorization.h"

#include "solvers/mpi_launcher.h"

#include "solvers/supernodal_cholesky.h"
#include "solvers/supernodal_solve.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/sparse_direct.h>

#include <cholmod.h>
#include <dlfcn.h>
#include <unistd.h>
#include <metis.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

namespace modal_haptics
{
  using dealii::ExcMessage;

  int set_openblas_threads(const int threads)
  {
    auto *set = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    auto *get = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    if (set == nullptr || get == nullptr)
      return 0;
    const int previous = get();
    set(threads);
    return previous;
  }

  std::vector<int> nested_dissection_of_nodes(NodeGraph &graph)
  {
    static_assert(sizeof(idx_t) == sizeof(int), "METIS's idx_t is expected to be 32 bits wide (Debian's)");
    std::vector<int> xadj(graph.degrees.size() + 1, 0);
    for (std::size_t g = 0; g < graph.degrees.size(); ++g)
      xadj[g + 1] = xadj[g] + graph.degrees[g];
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    idx_t            vertices = idx_t(graph.weights.size());
    std::vector<int> order(vertices), inverse(vertices);
    const int        status   = METIS_NodeND(&vertices, xadj.data(), graph.neighbours.data(), graph.weights.data(),
                                             options, order.data(), inverse.data());
    AssertThrow(status == METIS_OK,
                dealii::ExcMessage("METIS_NodeND failed (status " + std::to_string(status) + ", out of memory?)."));
    return order;
  }

  namespace
  {
    // Read once, before main: MPI_Init without a launcher (Open MPI's singleton start) puts
    // PMIX_RANK into this process's environment itself, so a look after it would take every run
    // for a launched one (and keep the VOIs from being meshed beside it).
    const bool launched_by_mpi = [] {
      for (const char *variable : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
        if (std::getenv(variable) != nullptr)
          return true;
      return false;
    }();
  } // namespace

  bool started_by_mpi_launcher()
  {
    return launched_by_mpi;
  }

  namespace
  {
    // The marker of a restart that set OPENBLAS_CORETYPE: the OpenBLAS core it replaced.
    constexpr const char *replaced_core_variable = "MODAL_HAPTICS_OPENBLAS_REPLACED_CORE";

    std::string openblas_core_name()
    {
      auto *core_name = reinterpret_cast<char *(*)()>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
      return core_name != nullptr ? std::string(core_name()) : std::string();
    }

    // OpenBLAS (a DYNAMIC_ARCH build, as Debian's) picks its kernels by the CPU's vendor, family and
    // model, and falls back to its generic Prescott (SSE3) kernels on a model its table lacks:
    // Debian 12's 0.3.21 on Intel's family 6 model 207 (Emerald Rapids, as some of our VMs report),
    // where DGEMM then runs several times slower (docs/performance.md, "OpenBLAS's kernels on a CPU
    // it does not know"). Only that fallback is replaced,
    // by the instruction sets the CPU and the OS support (GCC's __builtin_cpu_supports checks
    // both); a core OpenBLAS recognised is left alone. nullptr: nothing to replace.
    const char *blas_kernels_for_this_cpu()
    {
#if defined(__x86_64__)
      if (openblas_core_name() != "Prescott")
        return nullptr;
      __builtin_cpu_init();
      if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
          __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq"))
        return "SkylakeX";
      if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        return "Haswell";
#endif
      return nullptr;
    }

    // OpenBLAS reads OPENBLAS_THREAD_TIMEOUT when it loads and when it starts its workers: read the
    // variable again and restart the workers (its exported openblas_read_env, blas_thread_shutdown_,
    // blas_thread_init; found with dlsym, absent from other BLAS libraries). In the process instead
    // of a restart of it: starting this program again is slow, the dynamic linker binding the ~200
    // libraries deal.II brings (Debian links most with BIND_NOW; docs/performance.md, "One process
    // start").
    bool shorten_openblas_spin_in_process()
    {
      using Call          = int (*)();
      auto *read_env      = reinterpret_cast<void (*)()>(dlsym(RTLD_DEFAULT, "openblas_read_env"));
      auto *stop_workers  = reinterpret_cast<Call>(dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"));
      auto *start_workers = reinterpret_cast<Call>(dlsym(RTLD_DEFAULT, "blas_thread_init"));
      if (read_env == nullptr || stop_workers == nullptr || start_workers == nullptr)
        return false;
      read_env();
      stop_workers();
      start_workers();
      return true;
    }
  } // namespace

  // 2^20 cycles of spin (about 0.4 ms) is long enough for the factorization's back-to-back calls
  // (docs/performance.md). A process under an MPI launcher changes only the kernels: a process
  // that replaces itself under the launcher's daemon is one risk more, worth taking for DGEMM's
  // factor of 4, not for the spin. The kernels are chosen when OpenBLAS loads: only a restart
  // changes them.
  void apply_openblas_settings(char **argv)
  {
    bool spin_changed = false;
    if (std::getenv("OPENBLAS_THREAD_TIMEOUT") == nullptr && !started_by_mpi_launcher())
      {
        setenv("OPENBLAS_THREAD_TIMEOUT", "20", 0);
        spin_changed = true;
      }
    if (std::getenv("OPENBLAS_CORETYPE") == nullptr)
      if (const char *kernels = blas_kernels_for_this_cpu())
        {
          setenv("OPENBLAS_CORETYPE", kernels, 0);
          setenv(replaced_core_variable, openblas_core_name().c_str(), 1);
          execv("/proc/self/exe", argv); // returns only if it failed: then the run goes on as it is
        }
    if (spin_changed && !shorten_openblas_spin_in_process())
      execv("/proc/self/exe", argv); // an OpenBLAS without those calls: it reads the variable when it loads
  }

  BlasKernels running_blas_kernels()
  {
    auto *spin = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_thread_timeout"));
    return {openblas_core_name(), std::getenv(replaced_core_variable) != nullptr, spin != nullptr ? spin() : 0};
  }

  BlasThreads::BlasThreads(const int threads)
    : previous(set_openblas_threads(threads))
  {}

  BlasThreads::~BlasThreads()
  {
    if (previous > 0)
      set_openblas_threads(previous);
  }

  void Factorization::vmult(dealii::Vector<double> &dst, const dealii::Vector<double> &src)
  {
    dst = src;
    solve_block(dst.data(), 1);
  }

  namespace
  {
    const char *not_positive_definite_message =
      "The stiffness matrix K - shift*M is not positive definite. Either the part is not held (check the "
      "clamp groups: a free-floating part needs a negative 'Modes/Shift'), or 'Modes/Shift' lies above the "
      "first eigenfrequency.";

    // deal.II's thread count (the cores, or DEAL_II_NUM_THREADS), at most 8: beyond that the top of
    // the tree, solved by one thread, grows while the subtrees shrink.
    unsigned int solve_threads()
    {
      return std::clamp(dealii::MultithreadInfo::n_threads(), 1u, 8u);
    }

    // The node graph's nested dissection (nested_dissection_of_nodes) as CHOLMOD's Perm (Perm[k]:
    // the row of A that comes k-th).
    std::vector<SuiteSparse_long> node_graph_ordering(const dealii::SparsityPattern &pattern)
    {
      const std::size_t n          = pattern.n_rows();
      const auto        sorted_row = [&](const std::size_t row) {
        std::vector<std::size_t> columns;
        for (auto it = pattern.begin(row); it != pattern.end(row); ++it)
          columns.push_back(it->column());
        std::sort(columns.begin(), columns.end());
        return columns;
      };
      const auto       first_rows = node_first_rows(n, sorted_row);
      std::vector<int> node_of_row(n);
      for (std::size_t g = 0; g + 1 < first_rows.size(); ++g)
        std::fill(node_of_row.begin() + first_rows[g], node_of_row.begin() + first_rows[g + 1], int(g));
      NodeGraph graph =
        node_graph(first_rows, sorted_row, [&](const std::size_t column) { return node_of_row[column]; }, 0);

      std::vector<SuiteSparse_long> permutation;
      permutation.reserve(n);
      for (const int g : nested_dissection_of_nodes(graph))
        for (std::size_t row = first_rows[g]; row < first_rows[g + 1]; ++row)
          permutation.push_back(SuiteSparse_long(row));
      return permutation;
    }

  } // namespace

  FillOrdering cholmod_fill_ordering(const dealii::SparsityPattern &pattern)
  {
    dealii::Timer timer;
    FillOrdering  ordering{node_graph_ordering(pattern), 0.};
    ordering.seconds = timer.wall_time();
    return ordering;
  }

  namespace
  {
    class CholmodFactorization : public Factorization
    {
    public:
      // Analyzes A = K - shift M; factorizes it when the factor the analysis predicts takes at most
      // memory_limit bytes (fits() tells).
      CholmodFactorization(const dealii::SparseMatrix<double> &K,
                           const dealii::SparseMatrix<double> *M,
                           const double shift,
                           const double memory_limit,
                           FillOrdering ordering)
      {
        cholmod_l_start(&common);
        // One ordering, METIS nested dissection (the fill-reducing ordering that pays on 3D
        // meshes) of the node graph, given to CHOLMOD.
        common.nmethods           = 1;
        common.method[0].ordering = CHOLMOD_GIVEN;
        common.postorder          = 1;
        common.supernodal         = CHOLMOD_SUPERNODAL;
        // Silent: every failure of the analysis is thrown with its status below.
        common.print = 0;
        // CHOLMOD's supernodal analysis and layout; the numeric factorization is our own
        // (supernodal_cholesky.h says why).
        stats.method = "cholmod-supernodal-metis";

        cholmod_sparse *A = copy_matrix(K, M, shift);
        if (ordering.permutation.empty())
          ordering = cholmod_fill_ordering(K.get_sparsity_pattern());
        AssertThrow(ordering.permutation.size() == K.m(),
                    ExcMessage("Internal error: a fill-reducing ordering of " + std::to_string(ordering.permutation.size()) +
                               " rows for a matrix of " + std::to_string(K.m())));
        dealii::Timer timer;
        factor                     = cholmod_l_analyze_p(A, ordering.permutation.data(), nullptr, 0, &common);
        const int  analysis_status = common.status;
        const bool analyzed        = factor != nullptr && analysis_status == CHOLMOD_OK;
        stats.analyze_seconds      = ordering.seconds + timer.wall_time();
        // The supernodal analysis sizes the factor's values (xsize doubles) before any is computed.
        stats.predicted_factor_bytes = analyzed ? 8. * double(factor->xsize) : 0.;
        fits_in_memory               = stats.predicted_factor_bytes <= memory_limit;
        std::string factorization_error;
        bool        positive_definite = false;
        if (analyzed && fits_in_memory)
          {
            timer.restart();
            try
              {
                positive_definite =
                  factorize_supernodal(*A, *factor, common, solve_threads()) == SuiteSparse_long(factor->n);
              }
            catch (const std::exception &error)
              {
                factorization_error = error.what();
              }
            stats.factorize_seconds = timer.wall_time();
            // The analysis counted them.
            stats.factor_nonzeros = common.lnz;
            stats.factor_flops    = common.fl;
          }
        cholmod_l_free_sparse(&A, &common);
        if (!positive_definite)
          release();
        AssertThrow(analyzed, ExcMessage("CHOLMOD's analysis failed (status " + std::to_string(analysis_status) +
                                         ", out of memory?)."));
        if (!fits_in_memory)
          return;
        AssertThrow(factorization_error.empty(), ExcMessage("The supernodal factorization failed: " + factorization_error));
        AssertThrow(positive_definite, ExcMessage(not_positive_definite_message));
        try
          {
            triangular_solves   = std::make_unique<SupernodalSolve>(*factor, solve_threads());
            stats.solve_threads = triangular_solves->n_threads();
          }
        catch (...)
          {
            release();
            throw;
          }
      }

      bool fits() const { return fits_in_memory; }

      ~CholmodFactorization() override { release(); }

      // The triangular solves run on SupernodalSolve (subtrees of the elimination tree on parallel
      // threads, one BLAS thread each: supernodal_solve.h says why not cholmod_solve).
      void solve_block(double *columns, const unsigned int n_rhs) override
      {
        dealii::Timer     timer;
        const BlasThreads one_blas_thread(1);
        triangular_solves->solve(columns, n_rhs);
        stats.solve_seconds += timer.wall_time();
        stats.n_solved_vectors += n_rhs;
      }

      // The groups' kept solves may take half the memory available then (beside the factor).
      bool group_grams(const std::vector<GramGroup> &groups, std::vector<std::vector<double>> &grams) override
      {
        dealii::Timer     timer;
        const BlasThreads one_blas_thread(1);
        grams = triangular_solves->group_grams(groups, 0.5 * available_memory_bytes());
        stats.solve_seconds += timer.wall_time();
        for (const auto &group : groups)
          stats.n_solved_vectors += group.columns.size();
        return true;
      }

    private:
      // Frees the factor (if any) and CHOLMOD's workspace, once: by the destructor, by the
      // constructor's failure paths (after which no destructor runs) or when the factor does not fit.
      void release()
      {
        if (released)
          return;
        cholmod_l_free_factor(&factor, &common);
        cholmod_l_finish(&common);
        released = true;
      }

      // A = K - shift M with both triangles (deal.II's CSR rows are the CSC columns: the pattern is
      // symmetric), stype 1: CHOLMOD's analysis reads the upper one, the supernodal factorization
      // gathers a column of P A P^T from a whole column (supernodal_cholesky.h). M has K's sparsity
      // pattern, so its entries are walked in step.
      cholmod_sparse *copy_matrix(const dealii::SparseMatrix<double> &K, const dealii::SparseMatrix<double> *M,
                                  const double shift)
      {
        const auto      n = K.m();
        cholmod_sparse *A = cholmod_l_allocate_sparse(n, n, K.n_nonzero_elements(), /*sorted*/ 0, /*packed*/ 1,
                                                      /*stype*/ 1, CHOLMOD_REAL, &common);
        AssertThrow(A != nullptr, ExcMessage("CHOLMOD could not allocate a copy of the stiffness matrix (out of memory?)."));
        auto *column_start = static_cast<SuiteSparse_long *>(A->p);
        auto *row_index    = static_cast<SuiteSparse_long *>(A->i);
        auto *values       = static_cast<double *>(A->x);
        const bool  shifted = M != nullptr && shift != 0.;
        std::size_t k       = 0;
        for (std::size_t j = 0; j < n; ++j)
          {
            column_start[j] = k;
            auto m_it       = shifted ? M->begin(j) : K.begin(j);
            for (auto it = K.begin(j); it != K.end(j); ++it, ++m_it, ++k)
              {
                row_index[k] = it->column();
                values[k]    = shifted ? it->value() - shift * m_it->value() : it->value();
              }
          }
        column_start[n] = k;
        return A;
      }

      cholmod_common                   common;
      cholmod_factor                  *factor = nullptr;
      bool                             fits_in_memory = true;
      bool                             released       = false;
      std::unique_ptr<SupernodalSolve> triangular_solves;
    };

    class UmfpackFactorization : public Factorization
    {
    public:
      UmfpackFactorization(const dealii::SparseMatrix<double> &K,
                           const dealii::SparseMatrix<double> *M,
                           const double shift)
      {
        stats.method = "umfpack-lu";
        dealii::Timer timer;
        if (M != nullptr && shift != 0.)
          {
            shifted.reinit(K.get_sparsity_pattern());
            shifted.copy_from(K);
            shifted.add(-shift, *M);
            solver.initialize(shifted);
          }
        else
          solver.initialize(K);
        stats.factorize_seconds = timer.wall_time();
        size = K.m();
      }

      void solve_block(double *columns, const unsigned int n_rhs) override
      {
        dealii::Timer          timer;
        dealii::Vector<double> column(size);
        for (unsigned int c = 0; c < n_rhs; ++c)
          {
            std::copy(columns + c * size, columns + (c + 1) * size, column.begin());
            solver.solve(column);
            std::copy(column.begin(), column.end(), columns + c * size);
          }
        stats.solve_seconds += timer.wall_time();
        stats.n_solved_vectors += n_rhs;
      }

    private:
      dealii::SparseMatrix<double>  shifted;
      dealii::SparseDirectUMFPACK   solver;
      std::size_t                   size = 0;
    };
  } // namespace

  std::unique_ptr<Factorization> make_cholmod_factorization(const dealii::SparseMatrix<double> &K,
                                                            const dealii::SparseMatrix<double> *M,
                                                            const double shift, FillOrdering ordering)
  {
    return std::make_unique<CholmodFactorization>(K, M, shift, std::numeric_limits<double>::infinity(),
                                                  std::move(ordering));
  }

  std::unique_ptr<Factorization> make_cholmod_factorization_within(const dealii::SparseMatrix<double> &K,
                                                                   const dealii::SparseMatrix<double> *M,
                                                                   const double shift, const double memory_limit,
                                                                   double &predicted_factor_bytes, FillOrdering ordering)
  {
    auto factorization     = std::make_unique<CholmodFactorization>(K, M, shift, memory_limit, std::move(ordering));
    predicted_factor_bytes = factorization->statistics().predicted_factor_bytes;
    if (!factorization->fits())
      return nullptr;
    return factorization;
  }

  double available_memory_bytes()
  {
    std::ifstream meminfo("/proc/meminfo");
    std::string   key;
    double        kilobytes = 0.;
    while (meminfo >> key >> kilobytes)
      {
        if (key == "MemAvailable:")
          return 1024. * kilobytes;
        meminfo.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
      }
    return std::numeric_limits<double>::infinity(); // not Linux: the factorization is always tried
  }

  double memory_budget_bytes(const double limit_gb)
  {
    return limit_gb > 0. ? 1e9 * limit_gb : 0.5 * available_memory_bytes();
  }

  double memory_budget_per_process_bytes(const double limit_gb, const MPI_Comm comm)
  {
    return dealii::Utilities::MPI::min(memory_budget_bytes(limit_gb), comm) / processes_on_this_node(comm);
  }

  unsigned int processes_on_this_node(const MPI_Comm comm)
  {
    MPI_Comm node;
    MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    int count = 1;
    MPI_Comm_size(node, &count);
    MPI_Comm_free(&node);
    return count;
  }

  std::unique_ptr<Factorization> make_umfpack_factorization(const dealii::SparseMatrix<double> &K,
                                                            const dealii::SparseMatrix<double> *M,
                                                            const double shift)
  {
    return std::make_unique<UmfpackFactorization>(K, M, shift);
  }
} // namespace modal_haptics
