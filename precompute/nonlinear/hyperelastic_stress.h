// The first Piola-Kirchhoff stress, stored energy and tangent of the hyperelastic laws at one
// quadrature point (large_deformation.h's HyperelasticLaw), from the displacement gradient.
#pragma once

#include "nonlinear/large_deformation.h"

#include <deal.II/base/symmetric_tensor.h>
#include <deal.II/base/tensor.h>

#include <cmath>
#include <vector>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    inline const Tensor<2, 3> identity(unit_symmetric_tensor<3>());

    // P(F) and its directional derivative dP = A : G for the gradients G = e_c (x) g of the shape
    // functions (one nonzero row each) at one quadrature point. Strain, ln J and the stress are
    // computed from H = grad u, not from F = I + H, so that they keep their relative accuracy at
    // small strain (F^T F - I loses it to rounding: a 1e-3 N load on a steel beam, strains of
    // 1e-8, would leave Newton's residual above its tolerance).
    class StressAtPoint
    {
    public:
      StressAtPoint(const HyperelasticLaw law, const double mu, const double lambda, const Tensor<2, 3> &H)
        : law(law), mu(mu), lambda(lambda), F(identity + H)
      {
        const Tensor<2, 3> E = 0.5 * (H + transpose(H) + transpose(H) * H); // Green-Lagrange strain
        if (law == HyperelasticLaw::saint_venant_kirchhoff)
          {
            S = lambda * trace(E) * identity + 2. * mu * E;
            P = F * S;
            W = 0.5 * lambda * trace(E) * trace(E) + mu * scalar_product(E, E);
          }
        else
          {
            // J - 1 = tr H + (tr^2 H - tr H^2) / 2 + det H, and F - F^-T = F^-T (F^T F - I) = 2 F^-T E.
            const double J_minus_1 = trace(H) + 0.5 * (trace(H) * trace(H) - trace(H * H)) + determinant(H);
            F_inverse_T            = transpose(invert(F));
            log_J                  = std::log1p(J_minus_1);
            P                      = 2. * mu * F_inverse_T * E + lambda * log_J * F_inverse_T;
            W                      = mu * trace(E) - mu * log_J + 0.5 * lambda * log_J * log_J;
          }
      }

      const Tensor<2, 3> &stress() const { return P; }
      double              energy() const { return W; } // stored energy per reference volume

      // The tangent K_ij += JxW (A : G_j) : G_i for the shape functions' gradients G = e_c (x) g
      // (component c, gradient g): written out for rank-one G, so that a pair costs a few products.
      // St. Venant-Kirchhoff, with f_i = F^T e_ci (row ci of F):
      //   dP_j = G_j S + F (lambda tr dE I + 2 mu dE), dE = sym(F^T G_j) = sym(f_j (x) g_j), so
      //   K_ij = delta_cicj g_i.S g_j + lambda (f_i.g_i)(f_j.g_j) + mu ((F F^T)_cicj g_i.g_j + (F g_j)_ci (F g_i)_cj).
      // Neo-Hookean, with A = F^-T (d(F^-T) = -A dF^T A, d ln J = A : dF):
      //   dP_j = mu G_j + (mu - lambda ln J) A G_j^T A + lambda (A : G_j) A, so
      //   K_ij = mu delta_cicj g_i.g_j + (mu - lambda ln J)(A g_j)_ci (A g_i)_cj + lambda (A g_j)_cj (A g_i)_ci.
      // The three components of a vector element share their scalar shape function: g, F g (or A g)
      // and the dot products are formed once per pair of scalar functions (a, b), for its 3 x 3
      // block of DoFs (a, ci), (b, cj), b <= a, added to blocks[(a n + b) 9 + 3 ci + cj] (n scalar
      // functions; scatter_tangent_blocks puts them into the cell matrix once per cell: contiguous
      // blocks, no DoF index per quadrature point).
      void add_tangent(const Tensor<1, 3> *g, const unsigned int n, const double JxW, std::vector<Tensor<1, 3>> &work,
                       std::vector<double> &blocks) const
      {
        if (law == HyperelasticLaw::saint_venant_kirchhoff)
          add_tangent_blocks<true>(g, n, JxW, work, blocks);
        else
          add_tangent_blocks<false>(g, n, JxW, work, blocks);
      }

    private:
      // add_tangent for one law, with work[a] = F g_a (or A g_a) and JxW folded into the factors
      // once per function: an entry of a block costs two products (St. Venant-Kirchhoff's one more).
      template <bool svk>
      void add_tangent_blocks(const Tensor<1, 3> *g, const unsigned int n, const double JxW,
                              std::vector<Tensor<1, 3>> &work, std::vector<double> &blocks) const
      {
        const Tensor<2, 3> B = svk ? Tensor<2, 3>(mu * JxW * (F * transpose(F))) : Tensor<2, 3>();
        const double       shear = (svk ? mu : mu - lambda * log_J) * JxW, dilation = lambda * JxW;
        for (unsigned int a = 0; a < n; ++a)
          work[a] = svk ? Tensor<1, 3>(F * g[a]) : Tensor<1, 3>(F_inverse_T * g[a]); // F g_a, or A g_a
        for (unsigned int a = 0; a < n; ++a)
          {
            const Tensor<1, 3> wa = work[a], la = dilation * work[a];
            const Tensor<1, 3> Sg = svk ? Tensor<1, 3>(JxW * (S * g[a])) : Tensor<1, 3>(mu * JxW * g[a]);
            double            *block = &blocks[9 * a * n];
            for (unsigned int b = 0; b <= a; ++b, block += 9)
              {
                const Tensor<1, 3> sb       = shear * work[b];
                const Tensor<1, 3> wb       = work[b];
                const double       diagonal = Sg * g[b];
                for (unsigned int ci = 0; ci < 3; ++ci)
                  for (unsigned int cj = 0; cj < 3; ++cj)
                    block[3 * ci + cj] += sb[ci] * wa[cj] + la[ci] * wb[cj];
                block[0] += diagonal;
                block[4] += diagonal;
                block[8] += diagonal;
                if (svk)
                  {
                    const double gg = g[a] * g[b];
                    for (unsigned int k = 0; k < 9; ++k)
                      block[k] += gg * B[k / 3][k % 3];
                  }
              }
          }
      }

      const HyperelasticLaw law;
      const double          mu, lambda;
      const Tensor<2, 3>    F;
      Tensor<2, 3>          S, P, F_inverse_T;
      double                log_J = 0., W = 0.;
    };
  } // namespace nonlinear
} // namespace modal_haptics
