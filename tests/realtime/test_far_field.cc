// The far field (.mrt 1.3, FAR_COMPLIANCE): two contacts at candidates whose cross block is not
// stored are coupled by Z_a Z_b^T. modalrt_basis_pair_coupling names the rule that couples a pair;
// two HIPs held at far candidates settle to the static answer with it, by a snap contact and by a
// proxy; a file without it (a 1.2 file) couples them by the modes alone, as before.
#include "test_support.h"

#include <algorithm>
#include <array>

using modalrt::BasisContent;
using modalrt::LatticeOptions;

namespace
{
  constexpr std::uint32_t far_rank = 3;
  constexpr std::uint32_t tip      = 1; // the lattice's VOI space, where both contacts are

  LatticeOptions far_lattice()
  {
    LatticeOptions o;
    o.far_rank = far_rank;
    return o;
  }

  // The same content as a 1.2 file: no far field.
  BasisContent without_far_field(BasisContent content)
  {
    content.version_minor = 2;
    for (auto &space : content.spaces)
      space.far_compliance.clear();
    return content;
  }

  std::size_t candidate_of(const modalrt::BasisSpaceContent &s, std::uint32_t vertex)
  {
    return std::size_t(std::lower_bound(s.candidates.begin(), s.candidates.end(), vertex) - s.candidates.begin());
  }

  // Two HIPs, at vertices[0] and vertices[1] of the tip space, pressed by the forces F[0] and F[1].
  struct TwoPresses
  {
    std::uint32_t vertices[2];
    double        F[2][3];
  };

  // The reference from the file's content: u_a = sum_b (B_a Lambda^-1 B_b^T + C_ab) F_b, C_ab as the
  // specification gives it (modalrt::content_static_compliance: own, stored, Z_a Z_b^T, or none).
  std::array<double, 3> static_answer(const BasisContent &c, const TwoPresses &p, int a)
  {
    const modalrt::BasisSpaceContent &s = c.spaces[tip];
    std::array<double, 3>             u{};
    for (int b = 0; b < 2; ++b)
      {
        const auto G = modalrt::content_static_compliance(s, candidate_of(s, p.vertices[a]), candidate_of(s, p.vertices[b]));
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            u[i] += G[3 * i + j] * p.F[b][j];
      }
    return u;
  }

  // The kernel's answer: both contacts begun at their vertices (snap or proxy), the state settled to
  // the static equilibrium under the forces, one admittance tick; each contact's displacement from rest.
  std::array<std::array<double, 3>, 2> kernel_answer(const modalrt_basis *b, const TwoPresses &p, int contact_mode)
  {
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.hip_capacity       = 2;
    def.auto_release       = 0;
    def.contact_mode       = contact_mode;
    modalrt_kernel   *k    = test::create(b, def);
    modalrt_hip_input in[2];
    const double     *rest = modalrt_basis_display_vertices(b);
    for (std::uint32_t h = 0; h < 2; ++h)
      {
        in[h] = test::hip_at(rest + 3 * p.vertices[h], p.F[h][0], p.F[h][1], p.F[h][2]);
        ENSURE(modalrt_kernel_contact_begin(k, h, p.vertices[h]) == MODALRT_OK);
      }
    modalrt_hip_output out[2];
    ENSURE(modalrt_kernel_settle(k, in, 2) == MODALRT_OK);
    ENSURE(modalrt_kernel_tick_admittance(k, in, 2, out) == MODALRT_OK);
    std::array<std::array<double, 3>, 2> u{};
    for (int h = 0; h < 2; ++h)
      {
        ENSURE(out[h].in_contact == 1 && out[h].space == tip && out[h].active_vertex == p.vertices[h]);
        for (int d = 0; d < 3; ++d)
          u[h][d] = out[h].position[d] - rest[3 * p.vertices[h] + d];
      }
    modalrt_kernel_destroy(k);
    return u;
  }

  double norm(const std::array<double, 3> &x) { return std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]); }

  double difference(const std::array<double, 3> &x, const std::array<double, 3> &y)
  {
    return norm({x[0] - y[0], x[1] - y[1], x[2] - y[2]});
  }

  // Two far candidates of the tip space (no shared triangle: no stored block), pressed at once.
  TwoPresses far_presses(const LatticeOptions &o)
  {
    return {{modalrt::lattice_display_vertex(o, 6, 0), modalrt::lattice_display_vertex(o, 8, 2)},
            {{0.3, -0.2, -2.0}, {-0.1, 0.4, -1.0}}};
  }

  // (a) The kernel settles to u_a = sum_b (B_a Lambda^-1 B_b^T + C_ab) F_b with C_ab = Z_a Z_b^T for
  // the far pair, within 1e-9 relative, as a snap contact and as a proxy at the vertex; without the
  // far field the same presses differ from that answer by far more.
  void far_pair_settles_to_the_static_answer()
  {
    const LatticeOptions o       = far_lattice();
    const BasisContent   content = modalrt::make_lattice_cantilever(o);
    const TwoPresses     p       = far_presses(o);
    modalrt_basis       *far     = test::load(content);
    modalrt_basis       *without = test::load(without_far_field(content));
    ENSURE(modalrt_basis_pair_coupling(far, tip, p.vertices[0], p.vertices[1], nullptr) == MODALRT_COUPLING_FAR);
    for (int mode : {MODALRT_CONTACT_SNAP, MODALRT_CONTACT_PROXY})
      {
        const auto with_far    = kernel_answer(far, p, mode);
        const auto modes_alone = kernel_answer(without, p, mode);
        for (int a = 0; a < 2; ++a)
          {
            const std::array<double, 3> exact = static_answer(content, p, a);
            const double                error = difference(with_far[a], exact) / norm(exact);
            const double                apart = difference(modes_alone[a], exact) / norm(exact);
            std::printf("  %s HIP %d at vertex %u: |u| %.6g m, relative error %.2e with the far field, %.2e without\n",
                        mode == MODALRT_CONTACT_SNAP ? "snap " : "proxy", a, p.vertices[a], norm(exact), error, apart);
            ENSURE(error <= 1e-9);
            ENSURE(apart > 1e-4);
          }
      }
    modalrt_basis_destroy(far);
    modalrt_basis_destroy(without);
  }

  // (b) The rule per pair: 1 for a candidate with itself and for a stored pair (sharing a triangle),
  // 2 with C = Z_a Z_b^T for a far pair, 0 where a vertex is not a candidate or (without the far field)
  // for the far pair; pair_is_exact only for 1; the rank in modalrt_space_info.
  void pair_coupling_names_the_rule()
  {
    const LatticeOptions o       = far_lattice();
    const BasisContent   content = modalrt::make_lattice_cantilever(o);
    modalrt_basis       *far     = test::load(content);
    modalrt_basis       *without = test::load(without_far_field(content));
    const modalrt::BasisSpaceContent &s = content.spaces[tip];
    const std::uint32_t a = modalrt::lattice_display_vertex(o, 6, 0), b = modalrt::lattice_display_vertex(o, 8, 2);
    const std::uint32_t neighbour = modalrt::lattice_display_vertex(o, 7, 0);
    const std::uint32_t outside   = modalrt::lattice_display_vertex(o, 2, 1); // in the global space's region
    double              C[9];
    ENSURE(modalrt_basis_pair_coupling(far, tip, a, a, C) == MODALRT_COUPLING_EXACT);
    ENSURE(C[0] == s.candidate_compliance[9 * candidate_of(s, a)]);
    ENSURE(modalrt_basis_pair_coupling(far, tip, a, neighbour, C) == MODALRT_COUPLING_EXACT);
    ENSURE(modalrt_basis_pair_is_exact(far, tip, a, neighbour) == 1);

    ENSURE(modalrt_basis_pair_coupling(far, tip, a, b, C) == MODALRT_COUPLING_FAR);
    const std::array<double, 9> Z = modalrt::content_residual_block(s, candidate_of(s, a), candidate_of(s, b));
    double largest = 0.0;
    for (double z : Z)
      largest = std::max(largest, std::fabs(z));
    for (int e = 0; e < 9; ++e)
      ENSURE_NEAR(C[e], Z[e], 1e-14 * largest);
    ENSURE(largest > 0.0);
    ENSURE(modalrt_basis_pair_is_exact(far, tip, a, b) == 0);

    std::fill_n(C, 9, 1.0);
    ENSURE(modalrt_basis_pair_coupling(far, tip, a, outside, C) == MODALRT_COUPLING_NONE && C[4] == 0.0);
    ENSURE(modalrt_basis_pair_coupling(without, tip, a, b, C) == MODALRT_COUPLING_NONE && C[0] == 0.0);
    ENSURE(modalrt_basis_pair_coupling(without, tip, a, neighbour, nullptr) == MODALRT_COUPLING_EXACT);
    ENSURE(modalrt_basis_pair_coupling(far, 7, a, b, C) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_basis_pair_coupling(nullptr, tip, a, b, C) == MODALRT_ERROR_INVALID_ARGUMENT);

    modalrt_space_info info{};
    ENSURE(modalrt_basis_get_space_info(far, tip, &info) == MODALRT_OK && info.far_rank == far_rank);
    ENSURE(modalrt_basis_get_space_info(without, tip, &info) == MODALRT_OK && info.far_rank == 0);
    modalrt_basis_destroy(far);
    modalrt_basis_destroy(without);
  }

  // (d) A 1.2 file (no FAR_COMPLIANCE) loads as 1.2 and couples the far pair by the modes alone: the
  // kernel's answer is the reference without C_ab, as before the far field.
  void file_without_far_field_as_before()
  {
    const LatticeOptions o       = far_lattice();
    const BasisContent   content = without_far_field(modalrt::make_lattice_cantilever(o));
    const TwoPresses     p       = far_presses(o);
    modalrt_basis       *b       = test::load(content);
    modalrt_basis_info   info{};
    ENSURE(modalrt_basis_get_info(b, &info) == MODALRT_OK && info.version_minor == 2);
    const auto u = kernel_answer(b, p, MODALRT_CONTACT_SNAP);
    for (int a = 0; a < 2; ++a)
      {
        const std::array<double, 3> exact = static_answer(content, p, a); // C_ab = 0 for the far pair
        ENSURE(difference(u[a], exact) <= 1e-9 * norm(exact));
      }
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  far_pair_settles_to_the_static_answer();
  pair_coupling_names_the_rule();
  file_without_far_field_as_before();
  return test::finish("test_far_field");
}
