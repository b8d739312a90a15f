// What is derived from a checked basis once, at load: vertex normals, bounds, the spatial index,
// and the mode-norm bound that sizes the snap search.
#include "basis.h"

#include <mrt/cross_rows.h>
#include <mrt/surface_normals.h>

#include <algorithm>
#include <cmath>

namespace modalrt
{
  int ModalSpace::candidate_index(std::uint32_t vertex) const
  {
    const auto it = std::lower_bound(candidates.begin(), candidates.end(), vertex);
    return it != candidates.end() && *it == vertex ? int(it - candidates.begin()) : -1;
  }

  void vertex_mode_block(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, double *out)
  {
    const std::size_t n = 3 * std::size_t(space.mode_count), first = std::size_t(v) * n;
    if (basis.float64_modes())
      std::copy_n(space.display_modes_f64.data() + first, n, out);
    else
      std::copy_n(space.display_modes_f32.data() + first, n, out);
  }

  ModalSpace::Coupling ModalSpace::residual_coupling(const std::uint32_t a, const std::uint32_t b,
                                                     double C[9]) const noexcept
  {
    if (a == b)
      {
        std::copy_n(&candidate_compliance[9 * std::size_t(a)], 9, C);
        return Coupling::exact;
      }
    const std::ptrdiff_t stored =
      cross_count > 0 ? mrt::cross_position(cross_offsets.data(), cross_neighbours.data(), a, b) : -1;
    if (stored >= 0)
      {
        std::copy_n(&cross_blocks[9 * std::size_t(stored)], 9, C);
        return Coupling::exact;
      }
    if (far_rank == 0)
      return Coupling::none;
    mrt::far_coupling(far_compliance.data(), far_rank, a, b, C);
    return Coupling::far;
  }

  namespace
  {
    // The contract's vertex normals (mrt/surface_normals.h).
    void compute_normals(modalrt_basis &basis)
    {
      basis.normals.assign(basis.vertices.size(), 0.0);
      mrt::area_weighted_normals(basis.vertices.data(), basis.vertex_count, basis.triangles.data(), basis.triangle_count,
                                 basis.normals.data());
    }

    // Typical spacing of the display vertices: mean edge length, or the bounding box spread over
    // the vertices when there are no triangles.
    double typical_spacing(const modalrt_basis &basis)
    {
      const double *x     = basis.vertices.data();
      double        total = 0.0;
      for (std::size_t t = 0; t < basis.triangle_count; ++t)
        for (int k = 0; k < 3; ++k)
          {
            const std::uint32_t a = basis.triangles[3 * t + k], b = basis.triangles[3 * t + (k + 1) % 3];
            total += std::sqrt((x[3 * a] - x[3 * b]) * (x[3 * a] - x[3 * b]) +
                               (x[3 * a + 1] - x[3 * b + 1]) * (x[3 * a + 1] - x[3 * b + 1]) +
                               (x[3 * a + 2] - x[3 * b + 2]) * (x[3 * a + 2] - x[3 * b + 2]));
          }
      if (basis.triangle_count > 0 && total > 0.0)
        return total / (3.0 * basis.triangle_count);
      double diagonal = 0.0;
      for (int d = 0; d < 3; ++d)
        diagonal += (basis.bounds_max[d] - basis.bounds_min[d]) * (basis.bounds_max[d] - basis.bounds_min[d]);
      return std::sqrt(diagonal) / std::cbrt(double(std::max<std::uint32_t>(basis.vertex_count, 1)));
    }

    template <typename Scalar>
    double max_block_norm(const Scalar *modes, std::uint32_t nv, std::uint32_t r)
    {
      double worst = 0.0;
      for (std::size_t v = 0; v < nv; ++v)
        {
          double sum = 0.0;
          for (std::size_t k = 0; k < 3 * std::size_t(r); ++k)
            sum += double(modes[v * 3 * r + k]) * double(modes[v * 3 * r + k]);
          worst = std::max(worst, sum);
        }
      return std::sqrt(worst);
    }
  } // namespace

  void finish_basis(modalrt_basis &basis)
  {
    for (int d = 0; d < 3; ++d)
      {
        basis.bounds_min[d] = HUGE_VAL;
        basis.bounds_max[d] = -HUGE_VAL;
      }
    for (std::size_t v = 0; v < basis.vertex_count; ++v)
      for (int d = 0; d < 3; ++d)
        {
          basis.bounds_min[d] = std::min(basis.bounds_min[d], basis.vertices[3 * v + d]);
          basis.bounds_max[d] = std::max(basis.bounds_max[d], basis.vertices[3 * v + d]);
        }
    compute_normals(basis);
    build_surface_adjacency(basis.triangles.data(), basis.triangle_count, basis.vertex_count, basis.adjacency);
    basis.grid.build(basis.vertices.data(), basis.vertex_count, 1.5 * typical_spacing(basis));
    for (ModalSpace &space : basis.spaces)
      space.max_vertex_mode_norm =
        basis.float64_modes()
          ? max_block_norm(space.display_modes_f64.data(), basis.vertex_count, space.mode_count)
          : max_block_norm(space.display_modes_f32.data(), basis.vertex_count, space.mode_count);
  }

  namespace
  {
    // out (3 x (mode_end - mode_begin)) += w_k Phi_(patch vertex k), modes [mode_begin, mode_end),
    // for the patch entries k in [first, last) of the basis's patch arrays.
    void accumulate_patch(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t first, std::uint32_t last,
                          std::uint32_t mode_begin, std::uint32_t mode_end, double *out)
    {
      const std::size_t r = space.mode_count, n = mode_end - mode_begin;
      for (std::uint32_t k = first; k < last; ++k)
        {
          const double      w     = basis.patch_weights[k];
          const std::size_t start = std::size_t(basis.patch_vertices[k]) * 3 * r + mode_begin;
          if (n == r) // all modes: the vertex's 3 x r block is contiguous, one loop over it
            {
              if (basis.float64_modes())
                for (std::size_t i = 0; i < 3 * r; ++i)
                  out[i] += w * space.display_modes_f64[start + i];
              else
                for (std::size_t i = 0; i < 3 * r; ++i)
                  out[i] += w * double(space.display_modes_f32[start + i]);
              continue;
            }
          for (std::size_t c = 0; c < 3; ++c)
            {
              double *row = out + c * n;
              if (basis.float64_modes())
                for (std::size_t i = 0; i < n; ++i)
                  row[i] += w * space.display_modes_f64[start + c * r + i];
              else
                for (std::size_t i = 0; i < n; ++i)
                  row[i] += w * double(space.display_modes_f32[start + c * r + i]);
            }
        }
    }
  } // namespace

  void patch_row(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v, std::uint32_t mode_begin,
                 std::uint32_t mode_end, double *out)
  {
    std::fill_n(out, 3 * std::size_t(mode_end - mode_begin), 0.0);
    accumulate_patch(basis, space, basis.patch_offsets[v], basis.patch_offsets[v + 1], mode_begin, mode_end, out);
  }

  void add_patch_entries(const modalrt_basis &basis, const ModalSpace &space, std::uint32_t v,
                         std::uint32_t entry_begin, std::uint32_t entry_end, double *out)
  {
    const std::uint32_t first = basis.patch_offsets[v];
    accumulate_patch(basis, space, first + entry_begin, first + entry_end, 0, space.mode_count, out);
  }

  double blended_validity_force(const ModalSpace &space, const std::uint32_t *corners, const double *weights, int n,
                                int level) noexcept
  {
    if (space.validity_force.empty() || level < 0 || level > 2)
      return 0.0;
    double sum = 0.0, weight = 0.0;
    for (int k = 0; k < n; ++k)
      {
        const double F = space.validity_force[3 * std::size_t(corners[k]) + std::size_t(level)];
        if (weights[k] > 0.0 && F > 0.0)
          {
            sum += weights[k] * F;
            weight += weights[k];
          }
      }
    return weight > 0.0 ? sum / weight : 0.0;
  }
} // namespace modalrt
