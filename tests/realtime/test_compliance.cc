// modalrt_basis_contact_compliance on the lattice cantilever, whose stored numbers are exact for its
// model: at a candidate G = B Lambda^-1 B^T + C reproduces every full-FE validation response; at a
// vertex without a stored block G is the modal part, and a kernel settled under a constant force at
// that vertex is displaced by exactly G F. Bad arguments and allocation (none) are checked too.
#include "test_support.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

namespace
{
  // Counts the global operator new of this program while `counting` is set.
  std::atomic<long> allocations{0};
  std::atomic<bool> counting{false};
} // namespace

void *operator new(std::size_t size)
{
  if (counting.load(std::memory_order_relaxed))
    allocations.fetch_add(1, std::memory_order_relaxed);
  if (void *p = std::malloc(size ? size : 1))
    return p;
  throw std::bad_alloc();
}
void operator delete(void *p) noexcept { std::free(p); }
void operator delete(void *p, std::size_t) noexcept { std::free(p); }

namespace
{
  modalrt::LatticeOptions lattice()
  {
    modalrt::LatticeOptions o;
    o.patch_radius     = 0.03;
    o.candidate_stride = 2; // every other vertex of a region has no stored block
    return o;
  }

  // Every validation case: G e_dir equals the stored full static FE response.
  void candidates_give_the_full_fe_answer(const modalrt::BasisContent &c, const modalrt_basis *basis)
  {
    int cases = 0;
    for (std::uint32_t s = 0; s < c.spaces.size(); ++s)
      {
        const modalrt::BasisSpaceContent &space = c.spaces[s];
        for (std::size_t k = 0; 2 * k < space.validation_cases.size(); ++k)
          {
            const std::uint32_t vertex = space.validation_cases[2 * k], dir = space.validation_cases[2 * k + 1];
            double              G[9];
            std::uint32_t       full_fe = 7;
            counting                    = true; // the call alone: ENSURE itself builds strings
            const int status            = modalrt_basis_contact_compliance(basis, s, vertex, G, &full_fe);
            counting                    = false;
            ENSURE(status == MODALRT_OK && full_fe == 1);
            const double *reference = &space.validation_response[3 * k];
            const double  size      = std::sqrt(reference[0] * reference[0] + reference[1] * reference[1] +
                                                reference[2] * reference[2]);
            for (int d = 0; d < 3; ++d)
              ENSURE_NEAR(G[3 * d + dir], reference[d], 1e-9 * size);
            for (int a = 0; a < 3; ++a)
              for (int b = 0; b < 3; ++b)
                ENSURE_NEAR(G[3 * a + b], G[3 * b + a], 1e-12 * size);
            ++cases;
          }
      }
    ENSURE(cases > 0);
    std::printf("  %d validation cases reproduced by B Lambda^-1 B^T + C\n", cases);
  }

  // A vertex of the tip region without a stored block, in space 1.
  std::uint32_t non_candidate(const modalrt::BasisContent &c, const modalrt_basis *basis)
  {
    const std::uint32_t *candidates = modalrt_basis_candidates(basis, 1);
    modalrt_space_info   info;
    modalrt_basis_get_space_info(basis, 1, &info);
    for (std::uint32_t v = 0; v < c.region.size(); ++v)
      if (c.region[v] == 1 && !std::binary_search(candidates, candidates + info.candidate_count, v))
        return v;
    return MODALRT_NONE;
  }

  // The kernel settled under F at that vertex (its exact static equilibrium, then one admittance tick)
  // is displaced by G F: the same modal row as the kernel's, no correction.
  void other_vertices_give_the_modal_part(const modalrt::BasisContent &c, const modalrt_basis *basis)
  {
    const std::uint32_t vertex = non_candidate(c, basis);
    ENSURE(vertex != MODALRT_NONE);
    double        G[9];
    std::uint32_t full_fe = 7;
    counting              = true;
    const int status      = modalrt_basis_contact_compliance(basis, 1, vertex, G, &full_fe);
    counting              = false;
    ENSURE(status == MODALRT_OK && full_fe == 0);

    modalrt_kernel_def def  = modalrt_kernel_default_def();
    def.hip_capacity        = 1;
    def.initial_space       = 1;
    def.switch_rule         = MODALRT_SWITCH_NEVER;
    def.auto_release        = 0;
    modalrt_kernel   *kernel = test::create(basis, def);
    const double     *x      = &c.vertices[3 * vertex];
    modalrt_hip_input in     = test::hip_at(x, 0.3, -0.2, -1.5);
    ENSURE(modalrt_kernel_contact_begin(kernel, 0, vertex) == MODALRT_OK);
    ENSURE(modalrt_kernel_settle(kernel, &in, 1) == MODALRT_OK);
    modalrt_hip_output out;
    modalrt_kernel_tick_admittance(kernel, &in, 1, &out);
    double size = 0.0;
    for (int d = 0; d < 3; ++d)
      size += std::fabs(G[3 * d + 2] * in.force[2]);
    for (int d = 0; d < 3; ++d)
      {
        const double expected = G[3 * d] * in.force[0] + G[3 * d + 1] * in.force[1] + G[3 * d + 2] * in.force[2];
        ENSURE_NEAR(out.position[d] - x[d], expected, 1e-9 * size);
      }
    modalrt_kernel_destroy(kernel);
    std::printf("  vertex %u (no stored block): kernel settles to G F, modal part only\n", vertex);
  }

  // modalrt_basis_point_compliance (where a proxy sits): at a corner (weight 1) it is that vertex's
  // contact compliance; inside a triangle of a lattice whose every vertex is a candidate with the cross
  // compliance, it is the full model's compliance of the blended load, sum_a sum_b w_a w_b (B_a
  // Lambda^-1 B_b^T + C_ab), computed here from the content; with a corner that is not a candidate it
  // says it is not full FE. Bad weights are refused.
  void point_compliance(const modalrt_basis *basis)
  {
    modalrt::LatticeOptions o = lattice();
    o.all_candidates          = true;
    o.candidate_stride        = 1;
    const auto      content   = modalrt::make_lattice_cantilever(o);
    modalrt_basis  *all       = test::load(content);
    const uint32_t *triangles = modalrt_basis_display_triangles(all);
    const uint32_t  space     = 1;
    modalrt_space_info space_info;
    modalrt_basis_get_space_info(all, space, &space_info);
    const uint32_t *candidates = modalrt_basis_candidates(all, space);
    auto is_candidate = [&](uint32_t v) { return std::binary_search(candidates, candidates + space_info.candidate_count, v); };
    uint32_t t = 0; // a triangle away from the clamp: every corner a candidate
    while (!(is_candidate(triangles[3 * t]) && is_candidate(triangles[3 * t + 1]) && is_candidate(triangles[3 * t + 2])))
      ++t;
    const double    corner[3] = {0.0, 1.0, 0.0}, inside[3] = {0.2, 0.3, 0.5};
    double          G[9], V[9];
    uint32_t        full_fe = 0;
    const int status = modalrt_basis_point_compliance(all, space, t, corner, G, &full_fe);
    if (status != MODALRT_OK)
      std::printf("  %s (triangle %u)\n", modalrt_last_error_message(), t);
    ENSURE(status == MODALRT_OK && full_fe == 1);
    ENSURE(modalrt_basis_contact_compliance(all, space, triangles[3 * t + 1], V, nullptr) == MODALRT_OK);
    for (int k = 0; k < 9; ++k)
      ENSURE_NEAR(G[k], V[k], 1e-12 * std::fabs(V[8]));
    ENSURE(modalrt_basis_point_compliance(all, space, t, inside, G, &full_fe) == MODALRT_OK && full_fe == 1);
    const modalrt::BasisSpaceContent &s = content.spaces[space];
    const std::size_t r = s.eigenvalues.size(), n3 = 3 * s.candidates.size();
    auto index = [&](std::uint32_t v) { return std::size_t(std::find(s.candidates.begin(), s.candidates.end(), v) - s.candidates.begin()); };
    double worst = 0.0;
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d)
        {
          double exact = 0.0;
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              {
                const std::size_t ia = index(triangles[3 * t + a]), ib = index(triangles[3 * t + b]);
                double            sum = s.cross_compliance[(3 * ia + c) * n3 + 3 * ib + d];
                for (std::size_t i = 0; i < r; ++i)
                  sum += s.candidate_modes[(3 * ia + c) * r + i] * s.candidate_modes[(3 * ib + d) * r + i] / s.eigenvalues[i];
                exact += inside[a] * inside[b] * sum;
              }
          worst = std::max(worst, std::fabs(G[3 * c + d] - exact) / std::fabs(G[8]));
        }
    std::printf("  point compliance inside a triangle: within %.1e of the blended load's exact compliance\n", worst);
    ENSURE(worst < 1e-12);
    modalrt_basis_destroy(all);
    // On the stride-2 lattice some corner of some triangle is not a candidate: not full FE there.
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    bool some_not_full = false;
    for (uint32_t k = 0; k < info.display_triangle_count; ++k)
      {
        ENSURE(modalrt_basis_point_compliance(basis, 0, k, inside, G, &full_fe) == MODALRT_OK && G[8] > 0.0);
        some_not_full = some_not_full || full_fe == 0;
      }
    ENSURE(some_not_full);
    const double negative[3] = {-0.1, 0.6, 0.5}, short_sum[3] = {0.2, 0.3, 0.4};
    ENSURE(modalrt_basis_point_compliance(basis, 0, 0, negative, G, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_basis_point_compliance(basis, 0, 0, short_sum, G, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(std::string(modalrt_last_error_message()).find("sum to 1") != std::string::npos);
    ENSURE(modalrt_basis_point_compliance(basis, 0, info.display_triangle_count, inside, G, nullptr) ==
           MODALRT_ERROR_INVALID_ARGUMENT);
  }

  void bad_arguments(const modalrt_basis *basis)
  {
    double G[9];
    ENSURE(modalrt_basis_contact_compliance(nullptr, 0, 0, G, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_basis_contact_compliance(basis, 0, 0, nullptr, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_basis_contact_compliance(basis, 2, 0, G, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(modalrt_basis_contact_compliance(basis, 0, 1u << 30, G, nullptr) == MODALRT_ERROR_INVALID_ARGUMENT);
    ENSURE(std::string(modalrt_last_error_message()).find("modalrt_basis_contact_compliance") != std::string::npos);
    ENSURE(modalrt_basis_contact_compliance(basis, 0, 20, G, nullptr) == MODALRT_OK); // full_fe may be NULL
  }
} // namespace

int main()
{
  const modalrt::BasisContent content = modalrt::make_lattice_cantilever(lattice());
  modalrt_basis              *basis   = test::load(content);
  candidates_give_the_full_fe_answer(content, basis);
  other_vertices_give_the_modal_part(content, basis);
  bad_arguments(basis);
  ENSURE(allocations.load() == 0);
  point_compliance(basis);
  modalrt_basis_destroy(basis);
  return test::finish("test_compliance");
}
