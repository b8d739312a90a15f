// Which entries of W^T K^-1 W a space computes, and in which groups: a contact's own 3x3
// compliance at every display vertex (the felt-stiffness map; at the candidates also the static
// correction) and the cross blocks between candidates closer than the cross-compliance radius.
// Pure geometry (no deal.II): the display vertices' positions in, the plan out.
#pragma once

#include <array>
#include <vector>

namespace modal_haptics
{
  // The candidates within 'radius' of each candidate or sharing a display triangle with it (indices
  // into candidates, ascending, itself left out), as compressed rows: the neighbours of candidate a
  // are neighbours[offsets[a] .. offsets[a + 1]). A sliding contact blends the corners of its
  // triangle, so their cross blocks are always stored.
  struct CandidateNeighbours
  {
    std::vector<unsigned int> offsets{0}, neighbours;
    unsigned int count(unsigned int a) const { return offsets[a + 1] - offsets[a]; }
  };

  // A group of display vertices whose loads are solved together: its members (whose own
  // compliance, and whose cross blocks with their neighbours in this group or in its halo, the group
  // records), then the neighbours of its member candidates that are members of a later group (the
  // halo: not recorded; with a Cholesky factor of K their solves are borrowed from their own group,
  // SupernodalSolve::group_grams, else solved again here). A pair of neighbours in two groups is
  // recorded in the earlier one only; the later one's block is its transpose
  // (W_b^T R W_a = (W_a^T R W_b)^T).
  struct ContactGroup
  {
    std::vector<unsigned int> vertices; // display vertices: members first, then the halo
    unsigned int              n_members = 0;
    // Per halo vertex (in the order of vertices), the members (positions in vertices, ascending)
    // it is a neighbour of: the only blocks with it the group records.
    std::vector<std::vector<unsigned int>> halo_neighbours_of;
  };

  struct ContactBlockPlan
  {
    CandidateNeighbours       neighbours;
    std::vector<ContactGroup> groups; // every vertex of the plan is a member of exactly one
  };

  // positions: 3 per display vertex (any unit; radius in the same); vertices: those whose own
  // compliance is computed (ascending, a superset of candidates); candidates: ascending.
  // Members are grouped along a space-filling curve, so that a group lies close together in the
  // part (its loads share most of their elimination-tree paths), at most 'group_size' members each.
  // triangles: 3 display vertices each; radius < 0: no neighbours (no cross compliance).
  // links: more pairs of candidates (indices) that are neighbours whatever their distance (each
  // way), exact_pair_links' (with radius >= 0 only).
  ContactBlockPlan plan_contact_blocks(const std::vector<double> &positions, const std::vector<unsigned int> &triangles,
                                       const std::vector<unsigned int> &vertices,
                                       const std::vector<unsigned int> &candidates, double radius,
                                       unsigned int group_size,
                                       const std::vector<std::array<unsigned int, 2>> &links = {});

  CandidateNeighbours candidate_neighbours(const std::vector<double> &positions, const std::vector<unsigned int> &triangles,
                                           const std::vector<unsigned int> &candidates, double radius,
                                           const std::vector<std::array<unsigned int, 2>> &links = {});

  // The candidate (index) nearest to x within 'reach' (same units as positions), -1 if none.
  int nearest_candidate(const std::vector<double> &positions, const std::vector<unsigned int> &candidates,
                        const std::array<double, 3> &x, double reach);

  // The pairs of candidates (indices) that two hands pressing at 'points' (two each, same units as
  // positions) may load: every candidate within 'reach' of the first point, the candidate nearest
  // to it and those sharing a display triangle with that one, against the same set of the second
  // point (a candidate in both sets is not paired with itself). None for a point farther than
  // 'reach' from every candidate.
  std::vector<std::array<unsigned int, 2>> exact_pair_links(const std::vector<double> &positions,
                                                            const std::vector<unsigned int> &triangles,
                                                            const std::vector<unsigned int> &candidates,
                                                            const std::vector<std::array<std::array<double, 3>, 2>> &points,
                                                            double reach);
} // namespace modal_haptics
