// Which loads the static correction solves together (precompute/space/contact_blocks.h) and how the
// cross blocks it leaves to symmetry are completed (space_parts::complete_cross_blocks), on a
// triangulated 24 x 17 grid with every third vertex only a load (not a candidate) and one linked pair
// at opposite corners:
// * every load is a member of exactly one group, of at most 'group size' members;
// * a group's halo holds only candidates that are members of a later group;
// * every pair of neighbouring candidates is solved in exactly one group (the one holding both, with
//   the earlier one's member loaded), the linked far pair too;
// * the halo is at most 0.6 of what solving each pair in both groups would load (about half), and
//   each halo vertex lists exactly the members it is a neighbour of;
// * complete_cross_blocks fills each block no solve recorded with its pair's transpose, leaves the
//   recorded ones as they are, and throws when neither of a pair's blocks was recorded.
#include "checks.h"
#include "space/contact_blocks.h"
#include "space/space_parts.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace modal_haptics;
using testing::check;

namespace
{
  struct Grid
  {
    std::vector<double>       positions;
    std::vector<unsigned int> triangles, loads, candidates;
  };

  // nx x ny vertices 1 apart in the plane z = 0, two triangles a square; every third vertex is a
  // load but not a candidate.
  Grid make_grid(const unsigned int nx, const unsigned int ny)
  {
    Grid grid;
    for (unsigned int j = 0; j < ny; ++j)
      for (unsigned int i = 0; i < nx; ++i)
        {
          grid.positions.insert(grid.positions.end(), {double(i), double(j), 0.});
          const unsigned int v = j * nx + i;
          grid.loads.push_back(v);
          if (v % 3 != 2)
            grid.candidates.push_back(v);
        }
    for (unsigned int j = 0; j + 1 < ny; ++j)
      for (unsigned int i = 0; i + 1 < nx; ++i)
        {
          const unsigned int v = j * nx + i;
          grid.triangles.insert(grid.triangles.end(), {v, v + 1, v + nx + 1, v, v + nx + 1, v + nx});
        }
    return grid;
  }

  void check_plan()
  {
    const Grid         grid = make_grid(24, 17);
    const unsigned int group_size = 8;
    const std::vector<std::array<unsigned int, 2>> links{{{0, unsigned(grid.candidates.size() - 1)}}};
    const ContactBlockPlan plan = plan_contact_blocks(grid.positions, grid.triangles, grid.loads, grid.candidates,
                                                      1.5, group_size, links);
    std::map<unsigned int, int> member_group; // display vertex -> its group
    bool                        sizes_ok = true, members_once = true;
    for (unsigned int g = 0; g < plan.groups.size(); ++g)
      {
        sizes_ok = sizes_ok && plan.groups[g].n_members <= group_size && plan.groups[g].n_members > 0;
        for (unsigned int m = 0; m < plan.groups[g].n_members; ++m)
          members_once = member_group.emplace(plan.groups[g].vertices[m], int(g)).second && members_once;
      }
    check(sizes_ok && members_once && member_group.size() == grid.loads.size(),
          std::to_string(grid.loads.size()) + " loads, each a member of exactly one of " +
            std::to_string(plan.groups.size()) + " groups of at most " + std::to_string(group_size));

    bool         halo_later = true;
    std::size_t  halo_size  = 0;
    std::vector<std::set<unsigned int>> in_group(plan.groups.size());
    for (unsigned int g = 0; g < plan.groups.size(); ++g)
      {
        const auto &vertices = plan.groups[g].vertices;
        in_group[g].insert(vertices.begin(), vertices.end());
        halo_later = halo_later && in_group[g].size() == vertices.size(); // no vertex twice in a group
        for (std::size_t k = plan.groups[g].n_members; k < vertices.size(); ++k, ++halo_size)
          halo_later = halo_later && member_group.at(vertices[k]) > int(g);
      }
    check(halo_later, "every halo vertex is a member of a later group, once");

    // A pair (a, b) is solved in group g when one of them is a member of g and the other is in g.
    const auto                          &neighbours = plan.neighbours;
    std::size_t                          pairs = 0, solved_once = 0;
    std::vector<std::set<unsigned int>>  both_sides_halo(plan.groups.size()); // the old rule's halos
    for (unsigned int a = 0; a < grid.candidates.size(); ++a)
      for (unsigned int k = neighbours.offsets[a]; k < neighbours.offsets[a + 1]; ++k)
        {
          const unsigned int b = neighbours.neighbours[k];
          const unsigned int va = grid.candidates[a], vb = grid.candidates[b];
          const int          ga = member_group.at(va), gb = member_group.at(vb);
          if (ga != gb)
            both_sides_halo[ga].insert(vb);
          if (b < a)
            continue;
          ++pairs;
          unsigned int solving = 0;
          for (const int g : std::set<int>{ga, gb})
            solving += in_group[g].count(va) && in_group[g].count(vb);
          solved_once += solving == 1;
        }
    check(pairs > 0 && solved_once == pairs,
          std::to_string(solved_once) + " of " + std::to_string(pairs) +
            " neighbour pairs (the linked corners among them) solved in exactly one group");
    // Each halo vertex names exactly the members it is a neighbour of (the blocks the group records).
    std::map<unsigned int, unsigned int> candidate_index;
    for (unsigned int a = 0; a < grid.candidates.size(); ++a)
      candidate_index[grid.candidates[a]] = a;
    const auto are_neighbours = [&](const unsigned int va, const unsigned int vb) {
      const auto a = candidate_index.find(va), b = candidate_index.find(vb);
      if (a == candidate_index.end() || b == candidate_index.end())
        return false;
      const auto first = neighbours.neighbours.begin() + neighbours.offsets[a->second],
                 last  = neighbours.neighbours.begin() + neighbours.offsets[a->second + 1];
      return std::binary_search(first, last, b->second);
    };
    bool halo_lists_exact = true;
    for (const auto &group : plan.groups)
      {
        halo_lists_exact = halo_lists_exact && group.halo_neighbours_of.size() == group.vertices.size() - group.n_members;
        for (std::size_t h = 0; h < group.halo_neighbours_of.size() && halo_lists_exact; ++h)
          {
            std::vector<unsigned int> expected;
            for (unsigned int m = 0; m < group.n_members; ++m)
              if (are_neighbours(group.vertices[m], group.vertices[group.n_members + h]))
                expected.push_back(m);
            halo_lists_exact = group.halo_neighbours_of[h] == expected;
          }
      }
    check(halo_lists_exact, "each halo vertex lists exactly the members it is a neighbour of");
    std::size_t old_halo_size = 0;
    for (const auto &halo : both_sides_halo)
      old_halo_size += halo.size();
    check(halo_size > 0 && double(halo_size) <= 0.6 * double(old_halo_size),
          "halo " + std::to_string(halo_size) + " vertices, against " + std::to_string(old_halo_size) +
            " with each pair across two groups solved in both");
  }

  void check_completion()
  {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    // Three candidates, pairs (0, 1) and (1, 2): 0's block with 1 and 2's block with 1 recorded,
    // 1's two blocks left to symmetry.
    ModalSpaceResult result;
    result.cross_offsets    = {0, 1, 3, 4};
    result.cross_neighbours = {1, 0, 2, 1};
    result.cross_blocks.assign(36, nan);
    for (unsigned int i = 0; i < 9; ++i)
      {
        result.cross_blocks[i]      = 1. + i;  // (0, 1)
        result.cross_blocks[27 + i] = 20. + i; // (2, 1)
      }
    space_parts::complete_cross_blocks(result);
    bool transposed = true;
    for (unsigned int c = 0; c < 3; ++c)
      for (unsigned int d = 0; d < 3; ++d)
        transposed = transposed && result.cross_blocks[9 + 3 * c + d] == 1. + 3 * d + c &&
                     result.cross_blocks[18 + 3 * c + d] == 20. + 3 * d + c &&
                     result.cross_blocks[3 * c + d] == 1. + 3 * c + d;
    check(transposed, "complete_cross_blocks: the blocks left out are their pairs' transposes, the others kept");

    result.cross_blocks.assign(36, nan);
    bool threw = false;
    try
      {
        space_parts::complete_cross_blocks(result);
      }
    catch (const std::exception &error)
      {
        // deal.II wraps the message's lines: its words are looked for one by one.
        const std::string what = error.what();
        threw = what.find("candidates 0 and 1") != std::string::npos && what.find("neither") != std::string::npos;
      }
    check(threw, "complete_cross_blocks: a pair recorded from neither side is an error naming it");
  }
} // namespace

int main()
{
  check_plan();
  check_completion();
  return testing::exit_code();
}
