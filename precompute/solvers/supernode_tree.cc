#include "solvers/supernode_tree.h"

#include <algorithm>
#include <thread>

namespace modal_haptics
{
  using Index = SupernodeIndex;

  SupernodeTree supernode_tree(const cholmod_factor &factor)
  {
    const Index  n = factor.n, n_supernodes = factor.nsuper;
    const auto  *first_column = static_cast<const Index *>(factor.super);
    const auto  *row_start    = static_cast<const Index *>(factor.pi);
    const auto  *rows         = static_cast<const Index *>(factor.s);
    SupernodeTree tree;
    tree.supernode_of_column.resize(n);
    tree.parent.assign(n_supernodes, -1);
    tree.children.resize(n_supernodes);
    for (Index s = 0; s < n_supernodes; ++s)
      std::fill(tree.supernode_of_column.begin() + first_column[s], tree.supernode_of_column.begin() + first_column[s + 1],
                s);
    for (Index s = 0; s < n_supernodes; ++s)
      {
        const Index n_columns = first_column[s + 1] - first_column[s], n_rows = row_start[s + 1] - row_start[s];
        if (n_rows > n_columns)
          {
            tree.parent[s] = tree.supernode_of_column[rows[row_start[s] + n_columns]];
            tree.children[tree.parent[s]].push_back(s);
          }
        else
          tree.roots.push_back(s);
      }
    return tree;
  }

  namespace
  {
    // Packs the subtrees of 'roots' onto the threads (sorting the roots, heaviest first, each onto
    // the least loaded thread); returns the largest load, and each root's thread in thread_of when given.
    double pack_subtrees(const std::vector<double> &subtree_weight, const unsigned int threads,
                         std::vector<Index> &roots, std::vector<int> *thread_of)
    {
      std::sort(roots.begin(), roots.end(),
                [&](const Index a, const Index b) { return subtree_weight[a] > subtree_weight[b]; });
      std::vector<double> load(threads, 0.);
      for (const Index s : roots)
        {
          const auto lightest = std::min_element(load.begin(), load.end()) - load.begin();
          load[lightest] += subtree_weight[s];
          if (thread_of != nullptr)
            (*thread_of)[s] = int(lightest);
        }
      return *std::max_element(load.begin(), load.end());
    }

    // The top of the tree: again and again the heaviest subtree is cut off its root, which joins
    // the top, and its children's subtrees are packed instead; the cut that minimizes top + the most
    // loaded thread is kept. Cutting stops once the top alone costs more than that best (a
    // chain-like tree has no parallelism to give). Returns the supernodes of the top, in cut order.
    std::vector<Index> best_top(const SupernodeTree &tree, const std::vector<double> &weight,
                                const std::vector<double> &subtree_weight, const unsigned int threads)
    {
      std::vector<Index> candidates = tree.roots; // roots of the subtrees outside the top
      std::vector<Index> cuts;                    // the supernodes cut, in order
      std::size_t        best_n_cuts = 0;
      double             top = 0., best_cost = pack_subtrees(subtree_weight, threads, candidates, nullptr);
      while (threads > 1 && !candidates.empty() && !tree.children[candidates.front()].empty() && top < best_cost)
        {
          const Index heaviest = candidates.front();
          candidates.erase(candidates.begin());
          candidates.insert(candidates.end(), tree.children[heaviest].begin(), tree.children[heaviest].end());
          cuts.push_back(heaviest);
          top += weight[heaviest];
          const double cost = top + pack_subtrees(subtree_weight, threads, candidates, nullptr);
          if (cost < best_cost)
            {
              best_cost   = cost;
              best_n_cuts = cuts.size();
            }
        }
      cuts.resize(best_n_cuts);
      return cuts;
    }
  } // namespace

  TreeSplit split_tree(const SupernodeTree &tree, const std::vector<double> &weight, const unsigned int threads)
  {
    const Index n_supernodes = tree.parent.size();
    // A parent comes after its children: one ascending pass sums the subtrees.
    std::vector<double> subtree_weight = weight;
    for (Index s = 0; s < n_supernodes; ++s)
      if (tree.parent[s] >= 0)
        subtree_weight[tree.parent[s]] += subtree_weight[s];

    TreeSplit         split;
    std::vector<bool> in_top(n_supernodes, false);
    for (const Index s : best_top(tree, weight, subtree_weight, threads))
      {
        in_top[s] = true;
        split.top_weight += weight[s];
      }
    // The roots of the subtrees below the top are packed onto the threads, every other supernode
    // goes with its subtree's root.
    std::vector<Index> roots;
    for (Index s = 0; s < n_supernodes; ++s)
      if (!in_top[s] && (tree.parent[s] < 0 || in_top[tree.parent[s]]))
        roots.push_back(s);
    std::vector<int> thread_of(n_supernodes, -1);
    split.largest_thread_weight = pack_subtrees(subtree_weight, threads, roots, &thread_of);
    for (Index s = n_supernodes - 1; s >= 0; --s)
      if (!in_top[s] && thread_of[s] < 0)
        thread_of[s] = thread_of[tree.parent[s]];

    split.subtrees_of_thread.assign(threads, {});
    for (Index s = 0; s < n_supernodes; ++s)
      {
        split.total_weight += weight[s];
        if (in_top[s])
          split.top.push_back(s);
        else
          split.subtrees_of_thread[thread_of[s]].push_back(s);
      }
    return split;
  }

  void run_on_threads(const unsigned int threads, const std::function<void(unsigned int)> &work)
  {
    std::vector<std::thread> helpers;
    const auto               join_all = [&] {
      for (auto &helper : helpers)
        helper.join();
    };
    try
      {
        for (unsigned int t = 1; t < threads; ++t)
          helpers.emplace_back(work, t);
      }
    catch (...)
      {
        join_all();
        throw;
      }
    work(0);
    join_all();
  }
} // namespace modal_haptics
