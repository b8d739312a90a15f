#include "space/contact_blocks.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

namespace modal_haptics
{
  namespace
  {
    struct Box
    {
      std::array<double, 3> lower{}, upper{};
    };

    Box bounding_box(const std::vector<double> &positions, const std::vector<unsigned int> &vertices)
    {
      Box box;
      box.lower.fill(std::numeric_limits<double>::infinity());
      box.upper.fill(-std::numeric_limits<double>::infinity());
      for (const unsigned int v : vertices)
        for (unsigned int c = 0; c < 3; ++c)
          {
            box.lower[c] = std::min(box.lower[c], positions[3 * v + c]);
            box.upper[c] = std::max(box.upper[c], positions[3 * v + c]);
          }
      return box;
    }

    // The Morton (Z-order) key of a position quantized to 2^21 cells per axis of the box:
    // positions close in the key lie close in space.
    std::uint64_t morton_key(const Box &box, const double *x)
    {
      std::uint64_t key = 0;
      for (unsigned int c = 0; c < 3; ++c)
        {
          const double extent = std::max(box.upper[c] - box.lower[c], 1e-300);
          const auto   cell   = std::uint64_t(std::min(2097151., std::max(0., (x[c] - box.lower[c]) / extent * 2097151.)));
          for (unsigned int bit = 0; bit < 21; ++bit)
            key |= ((cell >> bit) & 1u) << (3 * bit + c);
        }
      return key;
    }

    double distance_squared(const std::vector<double> &positions, const unsigned int a, const unsigned int b)
    {
      double sum = 0.;
      for (unsigned int c = 0; c < 3; ++c)
        sum += std::pow(positions[3 * a + c] - positions[3 * b + c], 2);
      return sum;
    }

    double distance_to(const std::vector<double> &positions, const unsigned int v, const std::array<double, 3> &x)
    {
      double sum = 0.;
      for (unsigned int c = 0; c < 3; ++c)
        sum += std::pow(positions[3 * v + c] - x[c], 2);
      return std::sqrt(sum);
    }
  } // namespace

  namespace
  {
    // For each candidate, the candidates it shares a display triangle with (unsorted, repeated).
    std::vector<std::vector<unsigned int>> triangle_neighbours(const std::vector<unsigned int> &triangles,
                                                               const std::vector<unsigned int> &candidates,
                                                               const std::size_t n_vertices)
    {
      std::vector<int> candidate_of(n_vertices, -1);
      for (unsigned int a = 0; a < candidates.size(); ++a)
        candidate_of[candidates[a]] = int(a);
      std::vector<std::vector<unsigned int>> adjacent(candidates.size());
      for (std::size_t t = 0; t + 2 < triangles.size(); t += 3)
        for (unsigned int i = 0; i < 3; ++i)
          for (unsigned int j = 0; j < 3; ++j)
            if (i != j && candidate_of[triangles[t + i]] >= 0 && candidate_of[triangles[t + j]] >= 0)
              adjacent[candidate_of[triangles[t + i]]].push_back(candidate_of[triangles[t + j]]);
      return adjacent;
    }
  } // namespace

  // A uniform grid of cells of the radius' size: a candidate's neighbours lie in the 27 cells
  // around its own.
  CandidateNeighbours candidate_neighbours(const std::vector<double> &positions, const std::vector<unsigned int> &triangles,
                                           const std::vector<unsigned int> &candidates, const double radius,
                                           const std::vector<std::array<unsigned int, 2>> &links)
  {
    CandidateNeighbours result;
    result.offsets.assign(candidates.size() + 1, 0);
    if (radius < 0. || candidates.size() < 2)
      return result;
    auto adjacent = triangle_neighbours(triangles, candidates, positions.size() / 3);
    for (const auto &[a, b] : links)
      if (a != b)
        adjacent[a].push_back(b), adjacent[b].push_back(a);
    const Box  box  = bounding_box(positions, candidates);
    const auto cell = [&](const unsigned int v, const unsigned int c) {
      return std::int64_t(std::floor((positions[3 * v + c] - box.lower[c]) / radius));
    };
    const auto key = [](const std::int64_t i, const std::int64_t j, const std::int64_t k) {
      return (i * 2097152 + j) * 2097152 + k;
    };
    std::unordered_map<std::int64_t, std::vector<unsigned int>> cells; // candidate indices
    if (radius > 0.)
      for (unsigned int a = 0; a < candidates.size(); ++a)
        cells[key(cell(candidates[a], 0), cell(candidates[a], 1), cell(candidates[a], 2))].push_back(a);
    const double radius2 = radius * radius;
    for (unsigned int a = 0; a < candidates.size(); ++a)
      {
        const unsigned int va    = candidates[a];
        const std::size_t  first = result.neighbours.size();
        if (radius > 0.) // radius 0: the triangles' neighbours only
          for (std::int64_t di = -1; di <= 1; ++di)
            for (std::int64_t dj = -1; dj <= 1; ++dj)
              for (std::int64_t dk = -1; dk <= 1; ++dk)
                {
                  const auto found = cells.find(key(cell(va, 0) + di, cell(va, 1) + dj, cell(va, 2) + dk));
                  if (found == cells.end())
                    continue;
                  for (const unsigned int b : found->second)
                    if (b != a && distance_squared(positions, va, candidates[b]) <= radius2)
                      result.neighbours.push_back(b);
                }
        result.neighbours.insert(result.neighbours.end(), adjacent[a].begin(), adjacent[a].end());
        std::sort(result.neighbours.begin() + first, result.neighbours.end());
        result.neighbours.erase(std::unique(result.neighbours.begin() + first, result.neighbours.end()),
                                result.neighbours.end());
        result.offsets[a + 1] = result.neighbours.size();
      }
    return result;
  }

  ContactBlockPlan plan_contact_blocks(const std::vector<double> &positions, const std::vector<unsigned int> &triangles,
                                       const std::vector<unsigned int> &vertices,
                                       const std::vector<unsigned int> &candidates, const double radius,
                                       const unsigned int group_size,
                                       const std::vector<std::array<unsigned int, 2>> &links)
  {
    ContactBlockPlan plan;
    plan.neighbours = candidate_neighbours(positions, triangles, candidates, radius, links);
    if (vertices.empty())
      return plan;
    const Box                                          box = bounding_box(positions, vertices);
    std::vector<std::pair<std::uint64_t, unsigned int>> ordered;
    ordered.reserve(vertices.size());
    for (const unsigned int v : vertices)
      ordered.emplace_back(morton_key(box, &positions[3 * v]), v);
    std::sort(ordered.begin(), ordered.end());

    // Each pair of neighbours in two groups is solved once, in the earlier group: its halo holds
    // the neighbours that are members of a later group. The later group's member takes the pair's
    // block by symmetry (complete_cross_blocks). Solving it in both, as before, made the halo about
    // half of a group's columns (the default scene: 357 columns for 64 members).
    const std::size_t size = std::max(1u, group_size);
    std::vector<int>  member_group(positions.size() / 3, -1), in_halo_of(positions.size() / 3, -1);
    std::vector<unsigned int> halo_position(positions.size() / 3, 0); // in the group in_halo_of says
    for (std::size_t k = 0; k < ordered.size(); ++k)
      member_group[ordered[k].second] = int(k / size);
    for (std::size_t first = 0; first < ordered.size(); first += size)
      {
        const int    g = int(plan.groups.size());
        ContactGroup group;
        for (std::size_t k = first; k < std::min(ordered.size(), first + size); ++k)
          group.vertices.push_back(ordered[k].second);
        group.n_members = group.vertices.size();
        for (unsigned int m = 0; m < group.n_members; ++m)
          {
            const auto found = std::lower_bound(candidates.begin(), candidates.end(), group.vertices[m]);
            if (found == candidates.end() || *found != group.vertices[m])
              continue;
            const unsigned int a = found - candidates.begin();
            for (unsigned int k = plan.neighbours.offsets[a]; k < plan.neighbours.offsets[a + 1]; ++k)
              {
                const unsigned int vb = candidates[plan.neighbours.neighbours[k]];
                if (member_group[vb] <= g)
                  continue;
                if (in_halo_of[vb] != g)
                  {
                    halo_position[vb] = group.vertices.size() - group.n_members;
                    group.vertices.push_back(vb);
                    group.halo_neighbours_of.emplace_back();
                    in_halo_of[vb] = g;
                  }
                group.halo_neighbours_of[halo_position[vb]].push_back(m);
              }
          }
        plan.groups.push_back(std::move(group));
      }
    return plan;
  }

  int nearest_candidate(const std::vector<double> &positions, const std::vector<unsigned int> &candidates,
                        const std::array<double, 3> &x, const double reach)
  {
    int    nearest          = -1;
    double nearest_distance = reach;
    for (unsigned int a = 0; a < candidates.size(); ++a)
      if (const double d = distance_to(positions, candidates[a], x); d <= nearest_distance)
        nearest_distance = d, nearest = int(a);
    return nearest;
  }

  namespace
  {
    // The candidates (indices) a contact pressing at x may load: those within 'reach', the nearest
    // and the ones sharing a display triangle with it; empty if none is within reach.
    std::vector<unsigned int> candidates_around(const std::vector<double> &positions,
                                                const std::vector<unsigned int> &candidates,
                                                const std::vector<std::vector<unsigned int>> &adjacent,
                                                const std::array<double, 3> &x, const double reach)
    {
      const int nearest = nearest_candidate(positions, candidates, x, reach);
      if (nearest < 0)
        return {};
      std::vector<unsigned int> around(adjacent[nearest].begin(), adjacent[nearest].end());
      for (unsigned int a = 0; a < candidates.size(); ++a)
        if (distance_to(positions, candidates[a], x) <= reach)
          around.push_back(a);
      std::sort(around.begin(), around.end());
      around.erase(std::unique(around.begin(), around.end()), around.end());
      return around;
    }
  } // namespace

  std::vector<std::array<unsigned int, 2>> exact_pair_links(const std::vector<double> &positions,
                                                            const std::vector<unsigned int> &triangles,
                                                            const std::vector<unsigned int> &candidates,
                                                            const std::vector<std::array<std::array<double, 3>, 2>> &points,
                                                            const double reach)
  {
    std::vector<std::array<unsigned int, 2>> links;
    if (points.empty())
      return links;
    const auto adjacent = triangle_neighbours(triangles, candidates, positions.size() / 3);
    for (const auto &pair : points)
      {
        const auto first  = candidates_around(positions, candidates, adjacent, pair[0], reach);
        const auto second = candidates_around(positions, candidates, adjacent, pair[1], reach);
        for (const unsigned int a : first)
          for (const unsigned int b : second)
            if (a != b)
              links.push_back({{a, b}});
      }
    return links;
  }
} // namespace modal_haptics
