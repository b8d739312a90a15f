#include "synthetic_scene.h"

#include <mrt/patch_profile.h>
#include <mrt/surface_normals.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace modalrt
{
  namespace
  {
    constexpr double pi = 3.14159265358979323846;

    using Matrix = std::vector<double>; // dense, row-major

    // Cyclic Jacobi eigenvalue algorithm for a symmetric n x n matrix A (destroyed). Returns the
    // eigenvalues ascending and the eigenvectors as the columns of `vectors`.
    std::vector<double> symmetric_eigen(Matrix &A, std::size_t n, Matrix &vectors)
    {
      vectors.assign(n * n, 0.0);
      for (std::size_t i = 0; i < n; ++i)
        vectors[i * n + i] = 1.0;
      for (int sweep = 0; sweep < 100; ++sweep)
        {
          double off = 0.0, total = 0.0;
          for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = 0; j < n; ++j)
              (i == j ? total : off) += A[i * n + j] * A[i * n + j];
          if (off <= 1e-30 * (total + off))
            break;
          for (std::size_t p = 0; p < n; ++p)
            for (std::size_t q = p + 1; q < n; ++q)
              {
                const double apq = A[p * n + q];
                if (std::fabs(apq) < 1e-300)
                  continue;
                const double theta = (A[q * n + q] - A[p * n + p]) / (2.0 * apq);
                const double t     = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                for (std::size_t k = 0; k < n; ++k)
                  {
                    const double akp = A[k * n + p], akq = A[k * n + q];
                    A[k * n + p]     = c * akp - s * akq;
                    A[k * n + q]     = s * akp + c * akq;
                  }
                for (std::size_t k = 0; k < n; ++k)
                  {
                    const double apk = A[p * n + k], aqk = A[q * n + k];
                    A[p * n + k]     = c * apk - s * aqk;
                    A[q * n + k]     = s * apk + c * aqk;
                  }
                for (std::size_t k = 0; k < n; ++k)
                  {
                    const double vkp = vectors[k * n + p], vkq = vectors[k * n + q];
                    vectors[k * n + p] = c * vkp - s * vkq;
                    vectors[k * n + q] = s * vkp + c * vkq;
                  }
              }
        }
      std::vector<std::size_t> order(n);
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return A[a * n + a] < A[b * n + b]; });
      std::vector<double> values(n);
      Matrix              sorted(n * n);
      for (std::size_t k = 0; k < n; ++k)
        {
          values[k] = A[order[k] * n + order[k]];
          for (std::size_t i = 0; i < n; ++i)
            sorted[i * n + k] = vectors[i * n + order[k]];
        }
      vectors.swap(sorted);
      return values;
    }

    // Solves the SPD system A X = B (A n x n, B n x m, both row-major; B overwritten by X).
    void cholesky_solve(Matrix A, std::size_t n, Matrix &B, std::size_t m)
    {
      for (std::size_t j = 0; j < n; ++j)
        {
          double d = A[j * n + j];
          for (std::size_t k = 0; k < j; ++k)
            d -= A[j * n + k] * A[j * n + k];
          if (!(d > 0.0))
            throw std::runtime_error("cholesky_solve: matrix not positive definite");
          A[j * n + j] = std::sqrt(d);
          for (std::size_t i = j + 1; i < n; ++i)
            {
              double s = A[i * n + j];
              for (std::size_t k = 0; k < j; ++k)
                s -= A[i * n + k] * A[j * n + k];
              A[i * n + j] = s / A[j * n + j];
            }
        }
      for (std::size_t c = 0; c < m; ++c)
        {
          for (std::size_t i = 0; i < n; ++i)
            {
              double s = B[i * m + c];
              for (std::size_t k = 0; k < i; ++k)
                s -= A[i * n + k] * B[k * m + c];
              B[i * m + c] = s / A[i * n + i];
            }
          for (std::size_t i = n; i-- > 0;)
            {
              double s = B[i * m + c];
              for (std::size_t k = i + 1; k < n; ++k)
                s -= A[k * n + i] * B[k * m + c];
              B[i * m + c] = s / A[i * n + i];
            }
        }
    }

    // ---------------------------------------------------------------------------------------------
    // The display surface of a rectangular grid (shared by both scenes): vertices, triangles with
    // the outward normal +z, lumped vertex areas and contact patches.
    // ---------------------------------------------------------------------------------------------
    struct GridSurface
    {
      std::uint32_t nx, ny;
      std::vector<double> areas; // a third of the area of the triangles around each vertex
    };

    GridSurface make_grid_surface(BasisContent &c, std::uint32_t nx, std::uint32_t ny, double length, double width,
                                  double z)
    {
      GridSurface g{nx, ny, std::vector<double>(std::size_t(nx) * ny, 0.0)};
      for (std::uint32_t j = 0; j < ny; ++j)
        for (std::uint32_t i = 0; i < nx; ++i)
          c.vertices.insert(c.vertices.end(), {length * i / (nx - 1), width * j / (ny - 1), z});
      const double cell_area = length / (nx - 1) * width / (ny - 1);
      for (std::uint32_t j = 0; j + 1 < ny; ++j)
        for (std::uint32_t i = 0; i + 1 < nx; ++i)
          {
            const std::uint32_t a = j * nx + i, b = a + 1, d = a + nx, e = d + 1;
            c.triangles.insert(c.triangles.end(), {a, b, e, a, e, d});
            for (std::uint32_t v : {a, b, e, a, e, d})
              g.areas[v] += cell_area / 2.0 / 3.0;
          }
      return g;
    }

    // The patch of each vertex: vertices within rho, weights A_j (1 - (d/rho)^2)^2, normalized.
    void make_patches(BasisContent &c, const GridSurface &g, double rho)
    {
      const std::uint32_t nv = c.vertex_count();
      c.patch_offsets.assign(1, 0);
      for (std::uint32_t v = 0; v < nv; ++v)
        {
          std::vector<std::pair<std::uint32_t, double>> patch{{v, g.areas[v]}};
          for (std::uint32_t j = 0; j < nv && rho > 0.0; ++j)
            {
              if (j == v)
                continue;
              double d2 = 0.0;
              for (int k = 0; k < 3; ++k)
                d2 += (c.vertices[3 * j + k] - c.vertices[3 * v + k]) * (c.vertices[3 * j + k] - c.vertices[3 * v + k]);
              if (d2 < rho * rho)
                patch.push_back({j, g.areas[j] * mrt::patch_profile(std::sqrt(d2) / rho)});
            }
          double sum = 0.0;
          for (const auto &p : patch)
            sum += p.second;
          for (const auto &p : patch)
            {
              c.patch_vertices.push_back(p.first);
              c.patch_weights.push_back(p.second / sum);
            }
          c.patch_offsets.push_back(std::uint32_t(c.patch_vertices.size()));
        }
    }

    // ---------------------------------------------------------------------------------------------
    // The lattice cantilever
    // ---------------------------------------------------------------------------------------------
    struct Lattice
    {
      std::uint32_t              nodes = 0;
      std::vector<double>        x;          // 3 per node
      std::vector<int>           dof;        // 3 per node: free DoF index or -1 (clamped)
      std::size_t                n = 0;      // free DoFs
      double                     node_mass = 0.0;
      std::vector<double>        lambda;     // all n eigenvalues
      Matrix                     phi;        // n x n mass-normalized modes (columns)
    };

    std::uint32_t node_index(const LatticeOptions &o, std::uint32_t i, std::uint32_t j, std::uint32_t k)
    {
      return (k * o.ny + j) * o.nx + i;
    }

    Lattice solve_lattice(const LatticeOptions &o)
    {
      Lattice L;
      L.nodes = o.nx * o.ny * o.nz;
      const double h[3] = {o.length / (o.nx - 1), o.width / (o.ny - 1), o.thickness / (o.nz - 1)};
      for (std::uint32_t k = 0; k < o.nz; ++k)
        for (std::uint32_t j = 0; j < o.ny; ++j)
          for (std::uint32_t i = 0; i < o.nx; ++i)
            {
              L.x.insert(L.x.end(), {i * h[0], j * h[1], k * h[2]});
              for (int d = 0; d < 3; ++d)
                L.dof.push_back(i == 0 ? -1 : int(L.n++));
            }
      L.node_mass = o.density * o.length * o.width * o.thickness / L.nodes;

      Matrix       K(L.n * L.n, 0.0);
      const double spacing = std::cbrt(h[0] * h[1] * h[2]);
      for (std::uint32_t a = 0; a < L.nodes; ++a)
        for (std::uint32_t b = a + 1; b < L.nodes; ++b)
          {
            double e[3], len2 = 0.0;
            bool   neighbour = true;
            for (int d = 0; d < 3; ++d)
              {
                e[d] = L.x[3 * b + d] - L.x[3 * a + d];
                neighbour = neighbour && std::fabs(e[d]) < 1.5 * h[d];
                len2 += e[d] * e[d];
              }
            if (!neighbour)
              continue;
            const double len = std::sqrt(len2), k_spring = o.stiffness_modulus * spacing * spacing / len;
            for (double &ed : e)
              ed /= len;
            for (int c = 0; c < 3; ++c)
              for (int d = 0; d < 3; ++d)
                {
                  const double kcd = k_spring * e[c] * e[d];
                  const int    ac = L.dof[3 * a + c], ad = L.dof[3 * a + d], bc = L.dof[3 * b + c], bd = L.dof[3 * b + d];
                  if (ac >= 0 && ad >= 0) K[ac * L.n + ad] += kcd;
                  if (bc >= 0 && bd >= 0) K[bc * L.n + bd] += kcd;
                  if (ac >= 0 && bd >= 0) K[ac * L.n + bd] -= kcd;
                  if (bc >= 0 && ad >= 0) K[bc * L.n + ad] -= kcd;
                }
          }
      // Equal lumped masses: K phi = lambda m phi is the symmetric problem (K / m) y = lambda y.
      for (double &k : K)
        k /= L.node_mass;
      L.lambda = symmetric_eigen(K, L.n, L.phi);
      for (double &p : L.phi)
        p /= std::sqrt(L.node_mass);
      return L;
    }

    // W_v^T phi_i for every mode i: the patch average of mode i at vertex v (3 x n).
    Matrix patch_projection(const LatticeOptions &o, const Lattice &L, const BasisContent &c, std::uint32_t v)
    {
      Matrix P(3 * L.n, 0.0);
      for (std::uint32_t e = c.patch_offsets[v]; e < c.patch_offsets[v + 1]; ++e)
        {
          const std::uint32_t vertex = c.patch_vertices[e];
          const std::uint32_t node   = node_index(o, vertex % o.nx, vertex / o.nx, o.nz - 1);
          for (int d = 0; d < 3; ++d)
            if (L.dof[3 * node + d] >= 0)
              for (std::size_t i = 0; i < L.n; ++i)
                P[d * L.n + i] += c.patch_weights[e] * L.phi[std::size_t(L.dof[3 * node + d]) * L.n + i];
        }
      return P;
    }

    // sum_{i in [first, last)} P_a[:, i] P_b[:, i]^T / lambda_i (3 x 3).
    std::array<double, 9> modal_compliance(const Lattice &L, const Matrix &Pa, const Matrix &Pb, std::size_t first,
                                           std::size_t last)
    {
      std::array<double, 9> C{};
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d)
          for (std::size_t i = first; i < last; ++i)
            C[3 * c + d] += Pa[c * L.n + i] * Pb[d * L.n + i] / L.lambda[i];
      return C;
    }

    void add_space(BasisContent &c, const LatticeOptions &o, const Lattice &L, std::uint32_t s,
                   const std::vector<Matrix> &projection, const std::vector<double> &com)
    {
      BasisSpaceContent sp;
      const std::uint32_t r = o.modes[s], nv = c.vertex_count();
      sp.name = s == 0 ? "global" : "tip";
      sp.eigenvalues.assign(L.lambda.begin(), L.lambda.begin() + r);
      sp.damping_ratios.assign(r, o.damping[s]);
      sp.display_modes.assign(3 * std::size_t(nv) * r, 0.0);
      for (std::uint32_t v = 0; v < nv; ++v)
        {
          const std::uint32_t node = node_index(o, v % o.nx, v / o.nx, o.nz - 1);
          for (int d = 0; d < 3; ++d)
            if (L.dof[3 * node + d] >= 0)
              for (std::uint32_t i = 0; i < r; ++i)
                sp.display_modes[(3 * std::size_t(v) + d) * r + i] = L.phi[std::size_t(L.dof[3 * node + d]) * L.n + i];
        }

      std::uint32_t eligible = 0;
      for (std::uint32_t v = 0; v < nv; ++v)
        if ((o.all_candidates || c.region[v] == s) && v % o.nx != 0 && eligible++ % o.candidate_stride == 0)
          sp.candidates.push_back(v);
      for (std::uint32_t v : sp.candidates)
        {
          for (int d = 0; d < 3; ++d)
            for (std::uint32_t i = 0; i < r; ++i)
              sp.candidate_modes.push_back(projection[v][d * L.n + i]);
          const auto C = modal_compliance(L, projection[v], projection[v], r, L.n);
          sp.candidate_compliance.insert(sp.candidate_compliance.end(), C.begin(), C.end());
        }
      if (o.felt_stiffness)
        {
          // The map of the precompute: along the contract's normals, the full compliance (all modes).
          std::vector<double> normals(3 * std::size_t(nv));
          mrt::area_weighted_normals(c.vertices.data(), nv, c.triangles.data(), c.triangles.size() / 3,
                                     normals.data());
          sp.felt_stiffness.assign(nv, 0.0);
          for (std::uint32_t v : sp.candidates)
            {
              const auto    G = modal_compliance(L, projection[v], projection[v], 0, L.n);
              const double *n = normals.data() + 3 * std::size_t(v);
              double        nGn = 0.0;
              for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                  nGn += n[a] * G[3 * a + b] * n[b];
              sp.felt_stiffness[v] = 1.0 / nGn;
            }
        }
      if (o.validity_force)
        {
          sp.validity_force.assign(3 * std::size_t(nv), 0.0);
          for (std::uint32_t v : sp.candidates)
            {
              const double x = c.vertices[3 * std::size_t(v)];
              for (int p = 0; p < 3; ++p)
                sp.validity_force[3 * std::size_t(v) + p] = (p == 0 ? 1 : 5 * p) * o.validity_unit * (1.0 + x / o.length);
              if (v % o.nx == o.nx - 1)
                sp.validity_force[3 * std::size_t(v) + 2] = 1e30;
            }
        }
      const std::size_t nc = sp.candidates.size(), n3 = 3 * nc;
      if (o.cross && nc > 0)
        {
          sp.cross_compliance.assign(n3 * n3, 0.0);
          for (std::size_t a = 0; a < nc; ++a)
            for (std::size_t b = 0; b < nc; ++b)
              {
                const auto C = modal_compliance(L, projection[sp.candidates[a]], projection[sp.candidates[b]], r, L.n);
                for (int i = 0; i < 3; ++i)
                  for (int j = 0; j < 3; ++j)
                    sp.cross_compliance[(3 * a + i) * n3 + 3 * b + j] = C[3 * i + j];
              }
        }

      if (o.participation)
        for (std::uint32_t i = 0; i < r; ++i)
          {
            double gamma[6] = {0, 0, 0, 0, 0, 0};
            for (std::uint32_t node = 0; node < L.nodes; ++node)
              {
                double phi[3] = {0, 0, 0}, rel[3];
                for (int d = 0; d < 3; ++d)
                  {
                    if (L.dof[3 * node + d] >= 0)
                      phi[d] = L.phi[std::size_t(L.dof[3 * node + d]) * L.n + i];
                    rel[d] = L.x[3 * node + d] - com[d];
                  }
                for (int d = 0; d < 3; ++d)
                  gamma[d] += L.node_mass * phi[d];
                // Rotation about axis e_k through the centre of mass moves the node by e_k x rel;
                // phi . (e_k x rel) = e_k . (rel x phi).
                const double rel_x_phi[3] = {rel[1] * phi[2] - rel[2] * phi[1], rel[2] * phi[0] - rel[0] * phi[2],
                                             rel[0] * phi[1] - rel[1] * phi[0]};
                for (int k = 0; k < 3; ++k)
                  gamma[3 + k] += L.node_mass * rel_x_phi[k];
              }
            sp.participation.insert(sp.participation.end(), gamma, gamma + 6);
          }

      for (std::uint32_t k = 0; k < std::min<std::size_t>(o.validation_vertices, nc); ++k)
        {
          const std::uint32_t v = sp.candidates[k * nc / std::min<std::size_t>(o.validation_vertices, nc)];
          const auto          C = modal_compliance(L, projection[v], projection[v], 0, L.n); // full K^-1
          for (std::uint32_t d = 0; d < 3; ++d)
            {
              sp.validation_cases.insert(sp.validation_cases.end(), {v, d});
              sp.validation_response.insert(sp.validation_response.end(), {C[d], C[3 + d], C[6 + d]});
            }
        }
      c.spaces.push_back(std::move(sp));
    }

    // T (k <- j) = (Phi_k^T A Phi_k)^-1 Phi_k^T A Phi_j over the display vertices (A: vertex areas).
    std::vector<double> least_squares_transfer(const BasisContent &c, const GridSurface &g, std::uint32_t k,
                                               std::uint32_t j)
    {
      const std::size_t rk = c.spaces[k].eigenvalues.size(), rj = c.spaces[j].eigenvalues.size();
      const std::vector<double> &Pk = c.spaces[k].display_modes, &Pj = c.spaces[j].display_modes;
      Matrix N(rk * rk, 0.0), rhs(rk * rj, 0.0);
      for (std::size_t row = 0; row < 3 * std::size_t(c.vertex_count()); ++row)
        {
          const double a = g.areas[row / 3];
          for (std::size_t p = 0; p < rk; ++p)
            {
              for (std::size_t q = 0; q < rk; ++q)
                N[p * rk + q] += a * Pk[row * rk + p] * Pk[row * rk + q];
              for (std::size_t q = 0; q < rj; ++q)
                rhs[p * rj + q] += a * Pk[row * rk + p] * Pj[row * rj + q];
            }
        }
      cholesky_solve(N, rk, rhs, rj);
      return rhs;
    }

    SceneScalars scene_scalars(double rho, double mass, const std::vector<double> &com,
                               const std::vector<double> &x, double node_mass)
    {
      SceneScalars s{rho, mass, {com[0], com[1], com[2]}, {}};
      for (std::size_t n = 0; n < x.size() / 3; ++n)
        {
          const double r[3] = {x[3 * n] - com[0], x[3 * n + 1] - com[1], x[3 * n + 2] - com[2]};
          const double r2   = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
              s.inertia[3 * a + b] += node_mass * ((a == b ? r2 : 0.0) - r[a] * r[b]);
        }
      return s;
    }

    // ---------------------------------------------------------------------------------------------
    // The analytic plate's made-up residual compliance between the candidates at vertices va and vb:
    // 1e-5 m/N on each axis times a Gaussian of their distance (SPD over any set of distinct vertices).
    // ---------------------------------------------------------------------------------------------
    double made_up_compliance(const BasisContent &c, std::uint32_t va, std::uint32_t vb)
    {
      const double *xa = &c.vertices[3 * std::size_t(va)], *xb = &c.vertices[3 * std::size_t(vb)];
      const double  d2 = (xa[0] - xb[0]) * (xa[0] - xb[0]) + (xa[1] - xb[1]) * (xa[1] - xb[1]);
      return 1e-5 * std::exp(-d2 / (0.02 * 0.02));
    }

    // Every pair of candidates, version 1.0's dense CROSS_COMPLIANCE.
    void add_dense_compliance(const BasisContent &c, BasisSpaceContent &sp)
    {
      const std::size_t nc = sp.candidates.size(), n3 = 3 * nc;
      sp.cross_compliance.assign(n3 * n3, 0.0);
      for (std::size_t a = 0; a < nc; ++a)
        for (std::size_t b = 0; b < nc; ++b)
          for (int i = 0; i < 3; ++i)
            sp.cross_compliance[(3 * a + i) * n3 + 3 * b + i] = made_up_compliance(c, sp.candidates[a], sp.candidates[b]);
      for (std::size_t a = 0; a < nc; ++a)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            sp.candidate_compliance.push_back(sp.cross_compliance[(3 * a + i) * n3 + 3 * a + j]);
    }

    // Every display vertex a candidate (candidate index = vertex), its pairs with the vertices it
    // shares a triangle with in version 1.1's compressed rows: what the precompute writes by default
    // (Contact/Cross compliance radius = 0). The pairs hold the dense form's numbers over 8: a row has
    // at most 6 neighbours at 0.9 of its diagonal, so the rows stay diagonally dominant and every set of
    // contacts gets an SPD compliance (the dense form's Gaussian cut to neighbours would not be).
    void add_neighbour_compliance(const BasisContent &c, BasisSpaceContent &sp)
    {
      const std::size_t nv = c.vertex_count();
      std::vector<std::vector<std::uint32_t>> adjacent(nv);
      for (std::size_t t = 0; t + 2 < c.triangles.size(); t += 3)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            if (i != j)
              adjacent[c.triangles[t + i]].push_back(c.triangles[t + j]);
      sp.cross_offsets.assign(1, 0);
      for (std::uint32_t a = 0; a < nv; ++a)
        {
          std::sort(adjacent[a].begin(), adjacent[a].end());
          adjacent[a].erase(std::unique(adjacent[a].begin(), adjacent[a].end()), adjacent[a].end());
          for (std::uint32_t b : adjacent[a])
            {
              sp.cross_neighbours.push_back(b);
              for (int k = 0; k < 9; ++k)
                sp.cross_blocks.push_back(k % 4 == 0 ? made_up_compliance(c, a, b) / 8.0 : 0.0);
            }
          sp.cross_offsets.push_back(std::uint32_t(sp.cross_neighbours.size()));
          for (int k = 0; k < 9; ++k)
            sp.candidate_compliance.push_back(k % 4 == 0 ? made_up_compliance(c, a, a) : 0.0);
        }
    }
  } // namespace

  BasisContent make_lattice_cantilever(const LatticeOptions &o)
  {
    const Lattice L = solve_lattice(o);
    BasisContent  c;
    c.float64_modes     = o.float64_modes;
    const GridSurface g = make_grid_surface(c, o.nx, o.ny, o.length, o.width, o.thickness);
    const std::uint32_t nv = c.vertex_count();
    for (std::uint32_t v = 0; v < nv; ++v)
      c.region.push_back(o.modes.size() > 1 && c.vertices[3 * v] >= o.voi_start * o.length - 1e-12 ? 1u : 0u);
    make_patches(c, g, o.patch_radius);

    std::vector<double> com(3, 0.0);
    for (std::uint32_t n = 0; n < L.nodes; ++n)
      for (int d = 0; d < 3; ++d)
        com[d] += L.x[3 * n + d] / L.nodes;
    c.scene_scalars = scene_scalars(o.patch_radius, L.node_mass * L.nodes, com, L.x, L.node_mass);

    std::vector<Matrix> projection(nv);
    for (std::uint32_t v = 0; v < nv; ++v)
      projection[v] = patch_projection(o, L, c, v);
    for (std::uint32_t s = 0; s < o.modes.size(); ++s)
      add_space(c, o, L, s, projection, com);
    if (o.transfers)
      for (std::uint32_t k = 0; k < c.spaces.size(); ++k)
        for (std::uint32_t j = 0; j < c.spaces.size(); ++j)
          if (k != j)
            c.transfers.push_back({k, j, least_squares_transfer(c, g, k, j)});
    if (o.far_rank > 0)
      {
        c = with_sparse_cross(std::move(c), true);
        for (std::uint32_t s = 0; s < c.spaces.size(); ++s)
          if (!c.spaces[s].candidates.empty())
            c.spaces[s].far_compliance = made_up_far_factor(c, s, o.far_rank, o.length, o.width);
      }
    return c;
  }

  std::vector<double> made_up_far_factor(const BasisContent &content, std::uint32_t space, std::uint32_t rank,
                                         double length, double width)
  {
    const BasisSpaceContent &sp    = content.spaces[space];
    double                   scale = 0.0;
    for (double x : sp.candidate_compliance)
      scale = std::max(scale, std::fabs(x));
    scale = std::sqrt(scale);
    std::vector<double> Z;
    for (std::uint32_t v : sp.candidates)
      {
        const double x = content.vertices[3 * std::size_t(v)], y = content.vertices[3 * std::size_t(v) + 1];
        for (int i = 0; i < 3; ++i)
          for (std::uint32_t j = 0; j < rank; ++j)
            Z.push_back(scale * std::cos(pi * (j + 1) * x / length + 2 * pi * i / 3 + y / width));
      }
    return Z;
  }

  std::array<double, 9> content_residual_block(const BasisSpaceContent &sp, std::size_t a, std::size_t b)
  {
    std::array<double, 9> C{};
    const std::size_t     n3 = 3 * sp.candidates.size();
    std::ptrdiff_t        stored = -1; // b's position in a's row
    for (std::size_t k = sp.cross_offsets.empty() ? 0 : sp.cross_offsets[a];
         !sp.cross_offsets.empty() && k < sp.cross_offsets[a + 1]; ++k)
      if (sp.cross_neighbours[k] == b)
        stored = std::ptrdiff_t(k);
    if (a == b)
      std::copy_n(&sp.candidate_compliance[9 * a], 9, C.begin());
    else if (!sp.cross_compliance.empty())
      for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j)
          C[3 * i + j] = sp.cross_compliance[(3 * a + i) * n3 + 3 * b + j];
    else if (stored >= 0)
      std::copy_n(&sp.cross_blocks[9 * std::size_t(stored)], 9, C.begin());
    else if (!sp.far_compliance.empty())
      {
        const std::size_t k = sp.far_compliance.size() / n3;
        for (std::size_t i = 0; i < 3; ++i)
          for (std::size_t j = 0; j < 3; ++j)
            for (std::size_t m = 0; m < k; ++m)
              C[3 * i + j] += sp.far_compliance[(3 * a + i) * k + m] * sp.far_compliance[(3 * b + j) * k + m];
      }
    return C;
  }

  // ---------------------------------------------------------------------------------------------
  // The analytic plate (benchmarks)
  // ---------------------------------------------------------------------------------------------
  BasisContent make_analytic_plate(const PlateOptions &o)
  {
    BasisContent c;
    c.float64_modes     = o.float64_modes;
    const GridSurface g = make_grid_surface(c, o.nx, o.ny, o.length, o.width, 0.0);
    const std::uint32_t nv = c.vertex_count(), r = o.modes;
    for (std::uint32_t v = 0; v < nv; ++v)
      c.region.push_back(o.spaces > 1 && c.vertices[3 * v] > 0.5 * o.length ? 1u : 0u);
    make_patches(c, g, o.patch_radius);
    const double mass = 1.0;
    c.scene_scalars   = {o.patch_radius, mass, {0.5 * o.length, 0.5 * o.width, 0}, {1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 2e-3}};

    for (std::uint32_t s = 0; s < o.spaces; ++s)
      {
        BasisSpaceContent sp;
        sp.name = s == 0 ? "global" : "voi_" + std::to_string(s);
        sp.display_modes.assign(3 * std::size_t(nv) * r, 0.0);
        for (std::uint32_t i = 0; i < r; ++i)
          {
            // Mode (m, n) of a plate clamped at x = 0: bending out of plane plus a small in-plane part.
            const double m = 0.5 + i % 16, n = double(i / 16);
            sp.eigenvalues.push_back(std::pow(2 * pi * 10.0 * (1.0 + i + 0.01 * s), 2));
            sp.damping_ratios.push_back(0.02);
            for (std::uint32_t v = 0; v < nv; ++v)
              {
                const double x = c.vertices[3 * v] / o.length, y = c.vertices[3 * v + 1] / o.width;
                const double w = std::sin(m * pi * x) * std::cos(n * pi * y);
                sp.display_modes[(3 * std::size_t(v) + 2) * r + i] = w;
                sp.display_modes[(3 * std::size_t(v) + 0) * r + i] = 0.05 * w * y;
                sp.display_modes[(3 * std::size_t(v) + 1) * r + i] = 0.05 * w * x;
              }
            for (int k = 0; k < 6; ++k)
              sp.participation.push_back(0.1 / (1.0 + i + k));
          }
        if (o.every_vertex_candidates)
          {
            sp.candidates.resize(nv);
            std::iota(sp.candidates.begin(), sp.candidates.end(), 0u);
          }
        else
          for (std::uint32_t k = 0; k < o.candidates; ++k)
            sp.candidates.push_back(((3 + 5 * k + 11 * s) % o.ny) * o.nx + (7 + 13 * k + 3 * s) % o.nx); // spread over the plate
        std::sort(sp.candidates.begin(), sp.candidates.end());
        sp.candidates.erase(std::unique(sp.candidates.begin(), sp.candidates.end()), sp.candidates.end());
        const std::size_t nc = sp.candidates.size();
        for (std::uint32_t v : sp.candidates)
          for (int d = 0; d < 3; ++d)
            for (std::uint32_t i = 0; i < r; ++i)
              {
                double b = 0.0;
                for (std::uint32_t e = c.patch_offsets[v]; e < c.patch_offsets[v + 1]; ++e)
                  b += c.patch_weights[e] * sp.display_modes[(3 * std::size_t(c.patch_vertices[e]) + d) * r + i];
                sp.candidate_modes.push_back(b);
              }
        if (o.every_vertex_candidates)
          add_neighbour_compliance(c, sp);
        else
          add_dense_compliance(c, sp);
        for (std::size_t a = 0; a < std::min<std::size_t>(nc, 4); ++a)
          for (std::uint32_t d = 0; d < 3; ++d)
            {
              sp.validation_cases.insert(sp.validation_cases.end(), {sp.candidates[a], d});
              for (int row = 0; row < 3; ++row)
                {
                  double u = sp.candidate_compliance[9 * a + 3 * row + d];
                  for (std::uint32_t i = 0; i < r; ++i)
                    u += sp.candidate_modes[(3 * a + row) * r + i] * sp.candidate_modes[(3 * a + d) * r + i] /
                         sp.eigenvalues[i];
                  sp.validation_response.push_back(u);
                }
            }
        c.spaces.push_back(std::move(sp));
        if (o.far_rank > 0 && o.every_vertex_candidates)
          c.spaces.back().far_compliance = made_up_far_factor(c, s, o.far_rank, o.length, o.width);
      }
    for (std::uint32_t k = 0; k < o.spaces; ++k)
      for (std::uint32_t j = 0; j < o.spaces; ++j)
        if (k != j)
          {
            std::vector<double> T(std::size_t(r) * r, 0.0);
            for (std::uint32_t i = 0; i < r; ++i)
              T[std::size_t(i) * r + i] = 1.0;
            c.transfers.push_back({k, j, std::move(T)});
          }
    return c;
  }
  std::array<double, 9> content_static_compliance(const BasisSpaceContent &sp, std::size_t a, std::size_t b)
  {
    std::array<double, 9> G = content_residual_block(sp, a, b);
    const std::size_t     r = sp.eigenvalues.size();
    for (std::size_t i = 0; i < 3; ++i)
      for (std::size_t j = 0; j < 3; ++j)
        for (std::size_t m = 0; m < r; ++m)
          G[3 * i + j] += sp.candidate_modes[(3 * a + i) * r + m] * sp.candidate_modes[(3 * b + j) * r + m] / sp.eigenvalues[m];
    return G;
  }

  BasisContent with_sparse_cross(BasisContent content, bool neighbours_only)
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges; // vertex pairs sharing a triangle
    for (std::size_t t = 0; t < content.triangles.size(); t += 3)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l)
          edges.emplace_back(content.triangles[t + k], content.triangles[t + l]);
    std::sort(edges.begin(), edges.end());
    for (auto &sp : content.spaces)
      {
        const std::size_t nc = sp.candidates.size(), n3 = 3 * nc;
        if (sp.cross_compliance.empty())
          continue;
        const auto kept = [&](std::size_t a, std::size_t b) {
          return b != a && (!neighbours_only || std::binary_search(edges.begin(), edges.end(),
                                                                   std::make_pair(sp.candidates[a], sp.candidates[b])));
        };
        sp.cross_offsets.assign(1, 0);
        for (std::size_t a = 0; a < nc; ++a)
          {
            for (std::size_t b = 0; b < nc; ++b)
              if (kept(a, b))
                {
                  sp.cross_neighbours.push_back(std::uint32_t(b));
                  for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                      sp.cross_blocks.push_back(sp.cross_compliance[(3 * a + i) * n3 + 3 * b + j]);
                }
            sp.cross_offsets.push_back(std::uint32_t(sp.cross_neighbours.size()));
          }
        sp.cross_compliance.clear();
      }
    return content;
  }
} // namespace modalrt
