#include "vertex_info.h"
#include "stiffness_map.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace modalrt_tool
{
  namespace
  {
    double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

    std::string space_label(const modalrt_basis *basis, std::uint32_t space)
    {
      modalrt_space_info info;
      modalrt_basis_get_space_info(basis, space, &info);
      return "space " + std::to_string(space) + " '" + info.name + "'";
    }

    // One line per space: the stiffness felt pressing straight in, and whether it is full FE.
    void print_felt_stiffness(const modalrt_basis *basis, std::uint32_t vertex, std::uint32_t region,
                              std::uint32_t space_count)
    {
      std::printf("  stiffness at the contact, pressing straight in along -n (static, 1 / (n^T G n); the hand feels "
                  "it times the haptic scale, realtime/README.md):\n");
      for (std::uint32_t s = 0; s < space_count; ++s)
        {
          double       compliance = 0.0;
          bool         full_fe    = false;
          const char  *mark       = s == region ? "  <- its region: a contact here has this" : "";
          if (normal_compliance(basis, s, vertex, compliance, full_fe) != MODALRT_OK)
            {
              std::printf("    at the contact in %s: none (a mode with omega = 0: a part that is not held has no "
                          "static stiffness)%s\n", space_label(basis, s).c_str(), mark);
              continue;
            }
          std::printf("    at the contact in %s: %.12g N/mm (%s)%s\n", space_label(basis, s).c_str(), 1e-3 / compliance,
                      full_fe ? "corrected: equals full FE" : "modal only: not a corrected contact", mark);
        }
    }
  } // namespace

  namespace
  {
    // n^T G n.
    double along(const double G[9], const double n[3])
    {
      double Gn[3];
      for (int c = 0; c < 3; ++c)
        Gn[c] = dot3(G + 3 * c, n);
      return dot3(n, Gn);
    }
  } // namespace

  int normal_compliance(const modalrt_basis *basis, std::uint32_t space, std::uint32_t vertex, double &compliance,
                        bool &full_fe)
  {
    double        G[9];
    std::uint32_t full = 0;
    const int     status = modalrt_basis_contact_compliance(basis, space, vertex, G, &full);
    if (status != MODALRT_OK)
      return status;
    compliance = along(G, modalrt_basis_display_normals(basis) + 3 * std::size_t(vertex));
    full_fe    = full != 0;
    return MODALRT_OK;
  }

  int point_normal_compliance(const modalrt_basis *basis, std::uint32_t space, std::uint32_t triangle,
                              const double weights[3], double rest[3], double normal[3], double &compliance,
                              bool &full_fe)
  {
    double        G[9];
    std::uint32_t full = 0;
    const int     status = modalrt_basis_point_compliance(basis, space, triangle, weights, G, &full);
    if (status != MODALRT_OK)
      return status;
    const std::uint32_t *corners = modalrt_basis_display_triangles(basis) + 3 * std::size_t(triangle);
    for (int d = 0; d < 3; ++d)
      {
        rest[d] = normal[d] = 0.0;
        for (int k = 0; k < 3; ++k)
          {
            rest[d] += weights[k] * modalrt_basis_display_vertices(basis)[3 * std::size_t(corners[k]) + d];
            normal[d] += weights[k] * modalrt_basis_display_normals(basis)[3 * std::size_t(corners[k]) + d];
          }
      }
    const double length = std::sqrt(dot3(normal, normal));
    for (int d = 0; d < 3; ++d)
      normal[d] /= length;
    compliance = along(G, normal);
    full_fe    = full != 0;
    return MODALRT_OK;
  }

  std::uint32_t nearest_vertex(const modalrt_basis *basis, const double point[3], double &distance)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    const double *x       = modalrt_basis_display_vertices(basis);
    std::uint32_t best    = 0;
    double        best_d2 = HUGE_VAL;
    for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
      {
        const double d[3] = {x[3 * v] - point[0], x[3 * v + 1] - point[1], x[3 * v + 2] - point[2]};
        if (dot3(d, d) < best_d2)
          {
            best_d2 = dot3(d, d);
            best    = v;
          }
      }
    distance = std::sqrt(best_d2);
    return best;
  }

  void print_vertex(const modalrt_basis *basis, std::uint32_t vertex)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    const double *x = modalrt_basis_display_vertices(basis) + 3 * std::size_t(vertex);
    const double *n = modalrt_basis_display_normals(basis) + 3 * std::size_t(vertex);
    std::printf("vertex %u of %u display vertices (body frame, at rest)\n", vertex, info.display_vertex_count);
    std::printf("  position  [%.9g %.9g %.9g] m = [%.6g %.6g %.6g] mm\n", x[0], x[1], x[2], 1e3 * x[0], 1e3 * x[1],
                1e3 * x[2]);
    std::printf("  normal    [%.9g %.9g %.9g] (outward, area-weighted: the contact's normal)\n", n[0], n[1], n[2]);
    const std::uint32_t region = modalrt_basis_display_regions(basis)[vertex];
    std::printf("  region    %s (DISPLAY_REGION: a contact here switches into it)\n",
                space_label(basis, region).c_str());
    // Every space is expressed on the whole display surface; a candidate has its correction stored.
    std::string candidate_of;
    for (std::uint32_t s = 0; s < info.space_count; ++s)
      {
        modalrt_space_info space;
        modalrt_basis_get_space_info(basis, s, &space);
        const std::uint32_t *candidates = modalrt_basis_candidates(basis, s);
        bool                 candidate  = false;
        for (std::uint32_t k = 0; k < space.candidate_count; ++k)
          candidate = candidate || candidates[k] == vertex;
        if (candidate)
          candidate_of += (candidate_of.empty() ? "" : ", ") + space_label(basis, s);
      }
    std::printf("  spaces    all %u (each holds the whole display surface); a corrected contact (candidate) "
                "of: %s\n", info.space_count, candidate_of.empty() ? "none" : candidate_of.c_str());
    print_felt_stiffness(basis, vertex, region, info.space_count);
    print_vertex_felt_stiffness(basis, vertex);
    print_vertex_validity(basis, vertex);
  }
} // namespace modalrt_tool
