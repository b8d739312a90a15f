// Two felt-stiffness maps compared vertex by vertex: where design B is stiffer or softer than design
// A (docs/accuracy.md, "Two designs compared"), for both stages: the tools on two .mrt files, the
// precompute on two variants it computed. C++17 standard library only.
//
// The matching rule. B is read at each display vertex of A:
//   - identity: when both surfaces have the same vertex count and every vertex of B lies within
//     `same_position_tolerance` of the vertex of A with the same index, they are the same surface
//     and vertex i of A is vertex i of B;
//   - closest point: otherwise each vertex of A is matched to the closest point of B's triangles
//     (found through a uniform grid of cells over B, so a map of 1e5 vertices takes well under a
//     second), and B's stiffness there is the barycentric blend of that triangle's vertices that
//     have a value, the weights renormalized over them (a weight of at most 1e-12 is rounding and
//     counts as none). On a planar stretch of surface this
//     reproduces a stiffness linear in position exactly; elsewhere its error is that of linear
//     interpolation over B's triangle, plus whatever the two surfaces differ by (the match
//     distance, reported per vertex).
// A vertex is compared where A has a value (> 0: 0 means not computed) and B has one at its match.
// A relative difference whose magnitude is at most the noise floor counts as no difference.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mrt
{
  // One design's map on its display surface, as arrays the caller owns.
  struct SurfaceMap
  {
    const double        *vertices       = nullptr; // 3 per vertex [m]
    std::size_t          vertex_count   = 0;
    const std::uint32_t *triangles      = nullptr; // 3 vertex indices per triangle
    std::size_t          triangle_count = 0;
    const double        *stiffness      = nullptr; // per vertex [N/m]; 0: not computed
  };

  enum class MatchRule
  {
    identity,     // the same surface: vertex i of A is vertex i of B
    closest_point // B's triangles: the closest point to each vertex of A, its barycentric blend
  };

  const char *match_rule_name(MatchRule rule); // "identity", "closest point"

  struct ComparisonOptions
  {
    double      same_position_tolerance = 1e-9; // [m] the identity rule's test, per vertex (distance)
    double      noise_floor_percent     = 1.0;  // |B - A| / A at or below it [%]: no difference
    std::size_t largest_count           = 10;   // how many of the largest |%| differences to list
  };

  // One vertex of A where both maps have a value.
  struct VertexDifference
  {
    std::uint32_t vertex         = 0;         // of A
    double        position[3]    = {0, 0, 0}; // A's vertex [m]
    double        a              = 0;         // A's stiffness [N/m]
    double        b              = 0;         // B's at the match [N/m]
    double        percent        = 0;         // 100 (b - a) / a
    double        match_distance = 0;         // [m] from A's vertex to the point of B read
  };

  struct MapComparison
  {
    MatchRule   rule = MatchRule::identity;
    std::size_t a_vertex_count = 0;
    std::size_t b_vertex_count = 0;
    std::size_t compared_count = 0;  // vertices with a value in both maps
    std::size_t a_without_value = 0; // A has no value (0) there
    std::size_t b_without_value = 0; // A has one, B none at the match
    double      noise_floor_percent = 0;
    std::size_t beyond_noise_count = 0; // compared vertices with |%| above the noise floor

    // The match over every vertex of A [m]: the largest distance and the 95th percentile (the value
    // of rank round(0.95 (n - 1)) in ascending order, report.json's quantile rule).
    double max_match_distance = 0, p95_match_distance = 0;

    // B / A over the compared vertices (0 when none; the median of an even count is the mean of
    // the two middle values).
    double ratio_min = 0, ratio_median = 0, ratio_max = 0;

    // Per vertex of A (a_vertex_count each): where it was matched, B's value there (0: none), and
    // where `compared` is 1 the difference B - A [N/m] and in % of A (0 elsewhere).
    std::vector<double>       match_distance;
    std::vector<double>       b_at_a;
    std::vector<std::uint8_t> compared;
    std::vector<double>       difference;
    std::vector<double>       percent;

    // The `largest_count` largest |%| differences, the largest first (ties in vertex order).
    std::vector<VertexDifference> largest;
  };

  // Compares B with A, read at A's vertices. Either map may be empty (nothing is compared then).
  MapComparison compare_maps(const SurfaceMap &a, const SurfaceMap &b, const ComparisonOptions &options = {});

  // The closest point of a triangle surface to any point, through a uniform grid of cells that each
  // list the triangles whose bounding box meets them. Built once, then queried per point.
  class ClosestPointGrid
  {
  public:
    explicit ClosestPointGrid(const SurfaceMap &surface);

    struct Hit
    {
      std::uint32_t triangle   = 0;         // its index in the surface
      double        weights[3] = {0, 0, 0}; // barycentric, of the triangle's three vertices
      double        distance   = 0;         // [m]
    };

    // False only for a surface without triangles.
    bool closest(const double point[3], Hit &hit) const;

  private:
    SurfaceMap                 surface_; // the caller's arrays, not copied
    double                     origin_[3] = {0, 0, 0};
    double                     cell_size_ = 1;
    std::size_t                cells_[3]  = {1, 1, 1};
    std::vector<std::uint32_t> cell_start_; // cell c's triangles: cell_triangles_[cell_start_[c] .. [c + 1])
    std::vector<std::uint32_t> cell_triangles_;

    void        size_cells();
    void        list_triangles();
    std::size_t cell_index(const std::size_t c[3]) const { return c[0] + cells_[0] * (c[1] + cells_[1] * c[2]); }
    void        cell_of(const double point[3], std::size_t c[3]) const;
    void        search_cell(const std::size_t c[3], const double point[3], Hit &best, bool &found) const;
    void search_ring(const std::size_t c[3], std::size_t ring, const double point[3], Hit &best, bool &found) const;
    double      distance_outside_shell(const double point[3], const std::size_t c[3], std::size_t ring) const;
  };
} // namespace mrt
