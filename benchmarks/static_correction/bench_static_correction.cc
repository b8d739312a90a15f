// bench-static-correction: cost per candidate vertex of the static correction's solves K^-1 W_v
// (three load directions per candidate) with the precompute's own factorization (CHOLMOD
// supernodal, METIS; precompute/factorization.h), in blocks of 1 (one solve per load, "one by
// one"), 3 (one candidate per block) and more (several candidates per block; the precompute's
// compute_static_correction used 16 candidates = 48 right-hand sides), and block 0: every load at
// once as W^T K^-1 W by forward solves on the loads' elimination-tree paths (Factorization::
// group_grams, what compute_static_correction does now wherever the factor is K's).
//
//   bench-static-correction K.csr [--blocks 1,3,12,48,0] [--candidates 16] [--repetitions 3]
//
// K is a space's stiffness matrix exported by modal-precompute ('Output/Export matrices'). The load
// of a candidate is a unit force in x, y and z on three consecutive DoFs spread over the mesh (a
// vertex's DoFs in deal.II's numbering of a vector-valued FESystem). A patch load spreads the
// same three columns over a few more DoFs; CHOLMOD's solve with a dense right-hand side costs the
// same either way. Each repetition solves the same candidates once per block size, in a rotating
// order (interleaved against the machine's load); the CSV gives ms per candidate (median, min,
// max over repetitions) and the one-by-one time over the blocked time of the same repetition.
// Block 0 takes the candidates as one group (every pair's W_a^T K^-1 W_b); the precompute's groups
// are 64 neighbouring display vertices and their neighbours (space/contact_blocks.h).
#include "../command_line.h"
#include "../eigensolver/csr_file.h"

#include "solvers/factorization.h"

#include <deal.II/base/timer.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
  struct Options
  {
    std::string                matrix;
    std::vector<std::uint32_t> blocks      = {1, 3, 12, 48, 0};
    unsigned int               candidates  = 16;
    int                        repetitions = 3;
  };

  Options parse(int argc, char **argv)
  {
    const char *usage = "bench-static-correction K.csr [--blocks 1,3,12,48,0] [--candidates N] [--repetitions N]";
    Options     o;
    modal_haptics_bench::parse_file_and_options(argc, argv, o.matrix, [&](const std::string &name, const std::string &value) {
      if (name == "--blocks")
        o.blocks = modal_haptics_bench::numbers(value);
      else if (name == "--candidates")
        o.candidates = std::stoul(value);
      else if (name == "--repetitions")
        o.repetitions = std::stoi(value);
      else
        return false;
      return true;
    }, usage);
    if (o.blocks.empty() || o.candidates == 0 || o.repetitions < 1)
      modal_haptics_bench::usage(usage);
    return o;
  }

  // The exported CSR as the deal.II matrix the precompute factorizes.
  struct Stiffness
  {
    dealii::SparsityPattern      pattern;
    dealii::SparseMatrix<double> matrix;
  };

  void to_dealii(const modal_haptics_bench::Csr &csr, Stiffness &K)
  {
    std::vector<unsigned int> row_lengths(csr.n);
    for (std::int64_t row = 0; row < csr.n; ++row)
      row_lengths[row] = csr.row_start[row + 1] - csr.row_start[row];
    K.pattern.reinit(csr.n, csr.n, row_lengths);
    for (std::int64_t row = 0; row < csr.n; ++row)
      for (auto k = csr.row_start[row]; k < csr.row_start[row + 1]; ++k)
        K.pattern.add(row, csr.columns[k]);
    K.pattern.compress();
    K.matrix.reinit(K.pattern);
    for (std::int64_t row = 0; row < csr.n; ++row)
      for (auto k = csr.row_start[row]; k < csr.row_start[row + 1]; ++k)
        K.matrix.set(row, csr.columns[k], csr.values[k]);
  }

  // Candidates spread evenly over the DoFs (away from the first and last vertex): the DoF of a load.
  std::size_t loaded_dof(const std::size_t n, const unsigned int candidates, const unsigned int load)
  {
    const std::size_t vertex = (load / 3 + 1) * (n / 3) / (candidates + 1);
    return 3 * vertex + load % 3;
  }

  // Solves the three loads of every candidate, `block` right-hand sides per solve (0: all at once
  // as W^T K^-1 W); returns seconds.
  double solve_candidates(modal_haptics::Factorization &factorization, std::size_t n, unsigned int candidates,
                          unsigned int block)
  {
    const unsigned int  loads = 3 * candidates;
    std::vector<double> X;
    dealii::Timer       timer;
    if (block == 0)
      {
        std::vector<modal_haptics::GramGroup> W(1);
        W[0].columns.resize(loads);
        for (unsigned int load = 0; load < loads; ++load)
          W[0].columns[load].emplace_back(loaded_dof(n, candidates, load), 1.);
        std::vector<std::vector<double>> grams;
        if (!factorization.group_grams(W, grams))
          throw std::runtime_error("group_grams declined");
        return timer.wall_time();
      }
    for (unsigned int first = 0; first < loads; first += block)
      {
        const unsigned int count = std::min(block, loads - first);
        X.assign(std::size_t(count) * n, 0.);
        for (unsigned int b = 0; b < count; ++b)
          {
            X[b * n + loaded_dof(n, candidates, first + b)] = 1.;
          }
        factorization.solve_block(X.data(), count);
      }
    return timer.wall_time();
  }
} // namespace

int main(int argc, char **argv)
{
  modal_haptics::apply_openblas_settings(argv);
  const Options o = parse(argc, argv);
  try
    {
      Stiffness K;
      to_dealii(modal_haptics_bench::read_csr(o.matrix), K);
      const std::size_t n             = K.matrix.m();
      auto              factorization = modal_haptics::make_cholmod_factorization(K.matrix, nullptr, 0.);
      const auto       &stats         = factorization->statistics();
      std::printf("# bench-static-correction: %s, %zu DoFs, %s: analyze %.2f s, factorize %.2f s, %.3g nonzeros in L\n",
                  o.matrix.c_str(), n, stats.method.c_str(), stats.analyze_seconds, stats.factorize_seconds,
                  stats.factor_nonzeros);
      solve_candidates(*factorization, n, 1, 3); // warm-up: CHOLMOD's workspace, the factor in cache
      std::vector<std::vector<double>> seconds(o.blocks.size());
      for (int k = 0; k < o.repetitions; ++k)
        for (std::size_t j = 0; j < o.blocks.size(); ++j)
          {
            const std::size_t b = (j + k) % o.blocks.size();
            seconds[b].push_back(solve_candidates(*factorization, n, o.candidates, o.blocks[b]));
          }
      std::printf("n_dofs,rhs_per_solve,candidates,repetitions,ms_per_candidate_median,ms_per_candidate_min,"
                  "ms_per_candidate_max,one_by_one_over_blocked_median\n");
      const auto one_by_one = std::find(o.blocks.begin(), o.blocks.end(), 1u);
      for (std::size_t b = 0; b < o.blocks.size(); ++b)
        {
          std::vector<double> ms = seconds[b], speedup;
          for (double &s : ms)
            s *= 1e3 / o.candidates;
          std::sort(ms.begin(), ms.end());
          if (one_by_one != o.blocks.end())
            for (int k = 0; k < o.repetitions; ++k)
              speedup.push_back(seconds[one_by_one - o.blocks.begin()][k] / seconds[b][k]);
          std::sort(speedup.begin(), speedup.end());
          std::printf("%zu,%u,%u,%d,%.2f,%.2f,%.2f,%.2f\n", n, o.blocks[b], o.candidates, o.repetitions,
                      ms[ms.size() / 2], ms.front(), ms.back(), speedup.empty() ? 0. : speedup[speedup.size() / 2]);
        }
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "bench-static-correction: %s\n", e.what());
      return 1;
    }
  return 0;
}
