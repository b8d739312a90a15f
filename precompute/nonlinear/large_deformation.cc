// The geometrically nonlinear static solve and the validity analysis (large_deformation.h).
// Total Lagrangian: the unknown is the displacement u on the reference mesh, F = I + grad u, and
// the internal force is the integral of the first Piola-Kirchhoff stress P(F) against the shape
// functions' reference gradients; its derivative is the tangent, symmetric for a stored energy.
// One implementation for both backends: each process integrates over its own cells, the matrices
// and vectors exchange what crosses the partition (compress), and energies are summed.
#include "nonlinear/large_deformation.h"

#include "solvers/blas_lapack.h"
#include "solvers/factorization.h"
#include "solvers/mumps_inverse.h"
#include "assembly/elasticity.h"

#include <mrt/surface_normals.h>

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/point.h>
#include <deal.II/base/symmetric_tensor.h>
#include <deal.II/base/tensor.h>
#include <deal.II/base/thread_management.h>
#include <deal.II/base/timer.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/fe_values_extractors.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <tuple>
#include <type_traits>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    std::string law_name(const HyperelasticLaw law)
    {
      return law == HyperelasticLaw::neo_hookean ? "neo-Hookean" : "St. Venant-Kirchhoff";
    }

    namespace
    {
      const Tensor<2, 3> identity(unit_symmetric_tensor<3>());

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

      // The cubic term of the stored energy per reference volume at H = grad u (cubic_energy).
      double cubic_density(const HyperelasticLaw law, const double mu, const double lambda, const Tensor<2, 3> &H)
      {
        const Tensor<2, 3> eps   = 0.5 * (H + transpose(H));
        const Tensor<2, 3> sigma = lambda * trace(eps) * identity + 2. * mu * eps;
        double             psi   = 0.5 * scalar_product(sigma, transpose(H) * H);
        if (law == HyperelasticLaw::neo_hookean)
          psi += -lambda * trace(eps) * scalar_product(eps, eps) - 4. / 3. * mu * trace(eps * eps * eps);
        return psi;
      }

      // A symmetric 3 x 3 tensor as 6 numbers such that A : B = sum of the products of
      // as_row(A, 2) and as_row(B, 1): the off-diagonal entries weighted once by 2.
      void as_row(const Tensor<2, 3> &A, const double off_diagonal, double *row)
      {
        row[0] = A[0][0], row[1] = A[1][1], row[2] = A[2][2];
        row[3] = off_diagonal * 0.5 * (A[0][1] + A[1][0]);
        row[4] = off_diagonal * 0.5 * (A[0][2] + A[2][0]);
        row[5] = off_diagonal * 0.5 * (A[1][2] + A[2][1]);
      }
    } // namespace

    std::array<double, 2> lame_constants(const MaterialParameters &material)
    {
      const double E = material.youngs_modulus, nu = material.poissons_ratio;
      return {{E / (2. * (1. + nu)), E * nu / ((1. + nu) * (1. - 2. * nu))}};
    }

    HyperelasticLaw validity_law(const SceneParameters &scene)
    {
      return scene.contact.validity_neo_hookean ? HyperelasticLaw::neo_hookean : HyperelasticLaw::saint_venant_kirchhoff;
    }

    namespace
    {
      MPI_Comm communicator(const DoFHandler<3> &dof_handler)
      {
        return dof_handler.get_triangulation().get_communicator();
      }

      // This process's cells, in the DoF handler's order.
      std::vector<DoFHandler<3>::active_cell_iterator> locally_owned_cells(const DoFHandler<3> &dof_handler)
      {
        std::vector<DoFHandler<3>::active_cell_iterator> cells;
        for (const auto &cell : dof_handler.active_cell_iterators())
          if (cell->is_locally_owned())
            cells.push_back(cell);
        return cells;
      }

      // u readable at every DoF of this process's cells: a ghosted copy (serially a plain one).
      template <typename Algebra>
      typename Algebra::Vector readable(const SpaceView<Algebra> &space, const typename Algebra::Vector &u)
      {
        typename Algebra::Vector copy = space.ghosted_layout;
        copy                          = u;
        return copy;
      }

      // Psi3(u) [J], the cubic term of the stored energy's expansion in u about the reference state
      // (the elastic supports are quadratic: none), by the space's quadrature on every process's
      // cells. With H = grad u, eps = sym H, sigma = lambda tr(eps) I + 2 mu eps: St. Venant-Kirchhoff
      // psi3 = 1/2 sigma : (H^T H); the neo-Hookean law adds -lambda tr(eps) tr(eps^2) - 4/3 mu tr(eps^3)
      // (W = lambda/2 (tr E)^2 + mu tr E^2 - lambda tr E tr E^2 - 4/3 mu tr E^3 + O(E^4)).
      // With largest_gradient, also the largest |grad u| (Frobenius) at a quadrature point.
      template <typename Algebra>
      double cubic_energy(const SpaceView<Algebra> &space, const MaterialParameters &material,
                          const HyperelasticLaw law, const typename Algebra::Vector &u,
                          double *largest_gradient = nullptr)
      {
        const auto [mu, lambda] = lame_constants(material);
        const auto  u_read      = readable(space, u);
        FEValues<3> fe_values(space.mapping, space.dof_handler.get_fe(), space.quadrature,
                              update_gradients | update_JxW_values);
        const FEValuesExtractors::Vector displacement(0);
        std::vector<Tensor<2, 3>>        grad_u(space.quadrature.size());
        double                           psi3 = 0., largest = 0.;
        for (const auto &cell : space.dof_handler.active_cell_iterators())
          if (cell->is_locally_owned())
            {
              fe_values.reinit(cell);
              fe_values[displacement].get_function_gradients(u_read, grad_u);
              for (unsigned int q = 0; q < grad_u.size(); ++q)
                {
                  psi3 += cubic_density(law, mu, lambda, grad_u[q]) * fe_values.JxW(q);
                  largest = std::max(largest, grad_u[q].norm());
                }
            }
        if (largest_gradient)
          *largest_gradient = Utilities::MPI::max(largest, communicator(space.dof_handler));
        return Utilities::MPI::sum(psi3, communicator(space.dof_handler));
      }

      // Psi3 is the integral of a trilinear form c(H, H, H) with c(H_i, H_j, H_k) = X(H_i) . Y(H_j, H_k),
      // Y symmetric in j, k: St. Venant-Kirchhoff X = sigma_i, Y = 1/2 sym(H_j^T H_k); the neo-Hookean law
      // appends X = (tr eps_i, eps_i), Y = (-lambda eps_j : eps_k, -4/3 mu sym(eps_j eps_k)) (tr(ABC) of
      // symmetric tensors is A : sym(BC)). Over the quadrature points t = X^T Y is one GEMM per batch.
      // The tensor's part from cells [first, last) (r x r(r+1)/2, as ModalCubicTerm's t).
      template <typename VectorType>
      std::vector<double> cubic_tensor_part(const Mapping<3> &mapping, const FiniteElement<3> &fe,
                                            const Quadrature<3> &quadrature, const MaterialParameters &material,
                                            const HyperelasticLaw law, const unsigned int r,
                                            const std::vector<VectorType> &modes,
                                            const DoFHandler<3>::active_cell_iterator *first,
                                            const DoFHandler<3>::active_cell_iterator *last)
      {
        const auto [mu, lambda] = lame_constants(material);
        const bool         neo_hookean = law == HyperelasticLaw::neo_hookean;
        const unsigned int width = neo_hookean ? 13 : 6, n_pairs = r * (r + 1) / 2, n_q = quadrature.size();
        const unsigned int batch = 256; // quadrature points per GEMM
        FEValues<3> fe_values(mapping, fe, quadrature, update_gradients | update_JxW_values);
        const FEValuesExtractors::Vector       displacement(0);
        std::vector<std::vector<Tensor<2, 3>>> H(r, std::vector<Tensor<2, 3>>(n_q));
        std::vector<Tensor<2, 3>>              eps(r);
        const int                              rows = int(width * batch);
        std::vector<double>                    X(std::size_t(rows) * r, 0.), Y(std::size_t(rows) * n_pairs, 0.);
        std::vector<double>                    t(std::size_t(r) * n_pairs, 0.);
        unsigned int filled = 0; // quadrature points in the batch
        const auto   flush  = [&] {
          const int    m = r, n = n_pairs;
          const double one = 1.;
          if (filled > 0)
            dgemm_("T", "N", &m, &n, &rows, &one, X.data(), &rows, Y.data(), &rows, &one, t.data(), &m);
          std::fill(X.begin(), X.end(), 0.);
          std::fill(Y.begin(), Y.end(), 0.);
          filled = 0;
        };
        for (auto cell = first; cell != last; ++cell)
          {
            fe_values.reinit(*cell);
            for (unsigned int i = 0; i < r; ++i)
              fe_values[displacement].get_function_gradients(modes[i], H[i]);
            for (unsigned int q = 0; q < n_q; ++q)
              {
                const double      JxW = fe_values.JxW(q);
                const std::size_t row = std::size_t(width) * filled;
                for (unsigned int i = 0; i < r; ++i)
                  {
                    eps[i] = 0.5 * (H[i][q] + transpose(H[i][q]));
                    as_row(lambda * trace(eps[i]) * identity + 2. * mu * eps[i], 2., &X[i * std::size_t(rows) + row]);
                    if (neo_hookean)
                      {
                        X[i * std::size_t(rows) + row + 6] = trace(eps[i]);
                        as_row(eps[i], 2., &X[i * std::size_t(rows) + row + 7]);
                      }
                    for (unsigned int c = 0; c < width; ++c)
                      X[i * std::size_t(rows) + row + c] *= JxW;
                  }
                unsigned int pair = 0;
                for (unsigned int j = 0; j < r; ++j)
                  for (unsigned int k = j; k < r; ++k, ++pair)
                    {
                      double *y = &Y[pair * std::size_t(rows) + row];
                      as_row(0.5 * transpose(H[j][q]) * H[k][q], 1., y);
                      if (neo_hookean)
                        {
                          y[6] = -lambda * scalar_product(eps[j], eps[k]);
                          as_row(-4. / 3. * mu * eps[j] * eps[k], 1., y + 7);
                        }
                    }
                if (++filled == batch)
                  flush();
              }
          }
        flush();
        return t;
      }
    } // namespace

    // The cells are split into as many contiguous chunks as deal.II has threads, each integrated on
    // its own and the parts added in chunk order: the same numbers whichever task ends first.
    // Small GEMMs (r x 3328 x r(r+1)/2), one BLAS thread per task: with OpenBLAS' threads on a busy
    // machine the tensor's time swung by more than an order of magnitude between runs (docs/accuracy.md).
    template <typename VectorType>
    ModalCubicTerm::ModalCubicTerm(const DoFHandler<3> &dof_handler, const Mapping<3> &mapping,
                                   const Quadrature<3> &quadrature, const MaterialParameters &material,
                                   const HyperelasticLaw law, const std::vector<VectorType> &modes,
                                   const std::function<void(std::vector<double> &)> &sum_over_processes)
      : r(std::min<unsigned int>(modes.size(), max_estimate_modes))
    {
      Timer                                          timer;
      BlasThreads                                    one_thread(1);
      const auto        cells    = locally_owned_cells(dof_handler);
      const std::size_t n_chunks = std::clamp<std::size_t>(MultithreadInfo::n_threads(), 1, std::max<std::size_t>(cells.size(), 1));
      std::vector<std::vector<double>> parts(n_chunks);
      Threads::TaskGroup<>             tasks;
      for (std::size_t c = 0; c < n_chunks; ++c)
        tasks += Threads::new_task([&, c] {
          parts[c] = cubic_tensor_part(mapping, dof_handler.get_fe(), quadrature, material, law, r, modes,
                                       cells.data() + c * cells.size() / n_chunks,
                                       cells.data() + (c + 1) * cells.size() / n_chunks);
        });
      tasks.join_all();
      t.assign(std::size_t(r) * r * (r + 1) / 2, 0.);
      for (const auto &part : parts)
        for (std::size_t k = 0; k < t.size(); ++k)
          t[k] += part[k];
      sum_over_processes(t);
      seconds = timer.wall_time();
    }

    template ModalCubicTerm::ModalCubicTerm(const DoFHandler<3> &, const Mapping<3> &, const Quadrature<3> &,
                                            const MaterialParameters &, HyperelasticLaw,
                                            const std::vector<Vector<double>> &,
                                            const std::function<void(std::vector<double> &)> &);
    template ModalCubicTerm::ModalCubicTerm(const DoFHandler<3> &, const Mapping<3> &, const Quadrature<3> &,
                                            const MaterialParameters &, HyperelasticLaw,
                                            const std::vector<TrilinosWrappers::MPI::Vector> &,
                                            const std::function<void(std::vector<double> &)> &);

    double ModalCubicTerm::value(const std::vector<double> &q) const
    {
      AssertDimension(q.size(), r);
      double       psi3 = 0.;
      unsigned int pair = 0;
      for (unsigned int j = 0; j < r; ++j)
        for (unsigned int k = j; k < r; ++k, ++pair)
          {
            double row = 0.;
            for (unsigned int i = 0; i < r; ++i)
              row += t[std::size_t(pair) * r + i] * q[i];
            psi3 += (j == k ? 1. : 2.) * q[j] * q[k] * row;
          }
      return psi3;
    }

    namespace
    {
      // The least F > 0 with c3 F^2 + c2 F = rise (infinity if none), by the rounding-safe form of the roots.
      double least_positive_root(const double c3, const double c2, const double rise)
      {
        const double none = std::numeric_limits<double>::infinity();
        if (c3 == 0.)
          return c2 != 0. && rise / c2 > 0. ? rise / c2 : none;
        const double discriminant = c2 * c2 + 4. * c3 * rise;
        if (discriminant < 0.)
          return none;
        const double q     = -0.5 * (c2 + std::copysign(std::sqrt(discriminant), c2));
        double       least = none;
        for (const double root : {q / c3, q != 0. ? -rise / q : none})
          if (root > 0. && root < least)
            least = root;
        return least;
      }
    } // namespace

    std::array<double, 3> series_validity_forces(const double c1, const double c2, const double c3)
    {
      std::array<double, 3> forces;
      for (unsigned int k = 0; k < validity_departures.size(); ++k)
        {
          const double delta = validity_departures[k];
          forces[k]          = std::min(least_positive_root(c3, c2, c1 * delta / (1. - delta)),  // softening
                                        least_positive_root(c3, c2, -c1 * delta / (1. + delta))); // stiffening
        }
      return forces;
    }

    namespace
    {
      // The factorization of a tangent by the space's own direct solver, or null where the tangent
      // is not positive definite: CHOLMOD's Cholesky refuses it, MUMPS's L D L^T (with pivoting, for
      // an indefinite tangent factorizes too) counts its negative eigenvalues (Sylvester's inertia).
      // UMFPACK's and Amesos' LU do not tell: Newton then meets the limit point as a failed line search.
      std::unique_ptr<Factorization> factorize_tangent(const SparseMatrix<double> &tangent, const ModeParameters &modes)
      {
        try
          {
            return modes.factorization_kind == FactorizationKind::umfpack ? make_umfpack_factorization(tangent, nullptr, 0.) :
                                                                             make_cholmod_factorization(tangent, nullptr, 0.);
          }
        catch (const ExceptionBase &e)
          {
            if (std::string(e.what()).find("not positive definite") == std::string::npos)
              throw;
            return nullptr;
          }
      }

      std::unique_ptr<DistributedInverse> factorize_tangent(const TrilinosWrappers::SparseMatrix &tangent,
                                                            const ModeParameters                 &modes)
      {
        FactorizationStatistics statistics;
        auto inverse = make_mumps_inverse(tangent, modes.distributed_factorization, /*positive_definite*/ false,
                                          modes.factor_directory, statistics,
                                          [](const solver_choice::MumpsPrediction &) { return solver_choice::Placement::memory; });
        if (inverse->negative_eigenvalues() > 0)
          return nullptr;
        return inverse;
      }

      // The cell matrix from add_tangent's blocks (block (a, b), b <= a, and its transpose), local DoF
      // i at row and column position[i].
      void scatter_tangent_blocks(const std::vector<double> &blocks, const std::vector<std::array<unsigned int, 3>> &dof,
                                  const unsigned short *position, FullMatrix<double> &K)
      {
        const unsigned int n = dof.size();
        for (unsigned int a = 0; a < n; ++a)
          for (unsigned int b = 0; b <= a; ++b)
            {
              const double *block = &blocks[9 * (a * n + b)];
              for (unsigned int ci = 0; ci < 3; ++ci)
                for (unsigned int cj = 0; cj < 3; ++cj)
                  {
                    const unsigned int i = position[dof[a][ci]], j = position[dof[b][cj]];
                    K(i, j) = K(j, i) = block[3 * ci + cj];
                  }
            }
      }

      // The element is three copies of a scalar one (the displacement's components): DoF i is
      // component component[i] of scalar shape function scalar[i], and dof[s][c] the other way.
      struct VectorElementDofs
      {
        explicit VectorElementDofs(const FiniteElement<3> &fe)
          : component(fe.n_dofs_per_cell())
          , scalar(fe.n_dofs_per_cell())
          , dof(fe.base_element(0).n_dofs_per_cell())
        {
          AssertThrow(fe.n_base_elements() == 1 && fe.element_multiplicity(0) == 3, ExcInternalError());
          for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
            {
              std::tie(component[i], scalar[i]) = fe.system_to_component_index(i);
              dof[scalar[i]][component[i]]      = i;
            }
        }
        std::vector<unsigned int>                component, scalar;
        std::vector<std::array<unsigned int, 3>> dof;
      };

      // What every assembly reads of a cell's reference configuration (total Lagrangian: it never
      // changes), computed once per space instead of by FEValues at each of a contact's 20-odd
      // assemblies: the scalar shape functions' gradients and JxW at each quadrature point, and the
      // cell's DoFs (a cell's part is built in their ascending order).
      class ReferenceCells
      {
      public:
        ReferenceCells(const std::vector<DoFHandler<3>::active_cell_iterator> &cells, const Mapping<3> &mapping,
                       const FiniteElement<3> &fe, const Quadrature<3> &quadrature,
                       const std::vector<std::array<unsigned int, 3>> &dof)
          : n_q(quadrature.size())
          , n_scalar(dof.size())
          , dofs_per_cell(fe.n_dofs_per_cell())
          , gradients(cells.size() * n_q * n_scalar)
          , JxW_values(cells.size() * n_q)
          , sorted_dof_indices(cells.size() * dofs_per_cell)
          , sorted_position(cells.size() * dofs_per_cell)
        {
          parallel::apply_to_subranges(
            std::size_t(0), cells.size(),
            [&](const std::size_t begin, const std::size_t end) {
              FEValues<3>                          fe_values(mapping, fe, quadrature, update_gradients | update_JxW_values);
              std::vector<types::global_dof_index> indices(dofs_per_cell);
              std::vector<unsigned int>            order(dofs_per_cell);
              for (std::size_t c = begin; c < end; ++c)
                {
                  fe_values.reinit(cells[c]);
                  for (unsigned int q = 0; q < n_q; ++q)
                    {
                      JxW_values[c * n_q + q] = fe_values.JxW(q);
                      for (unsigned int a = 0; a < n_scalar; ++a)
                        gradients[(c * n_q + q) * n_scalar + a] = fe_values.shape_grad(dof[a][0], q);
                    }
                  cells[c]->get_dof_indices(indices);
                  assembly::ascending_dof_order(indices, order);
                  for (unsigned int k = 0; k < dofs_per_cell; ++k)
                    {
                      sorted_dof_indices[c * dofs_per_cell + k]     = indices[order[k]];
                      sorted_position[c * dofs_per_cell + order[k]] = k;
                    }
                }
            },
            64);
        }

        const unsigned int n_q, n_scalar, dofs_per_cell;
        // The n_scalar gradients at quadrature point q of cell c.
        const Tensor<1, 3> *gradients_at(const std::size_t c, const unsigned int q) const
        {
          return &gradients[(c * n_q + q) * n_scalar];
        }
        double JxW(const std::size_t c, const unsigned int q) const { return JxW_values[c * n_q + q]; }
        // The cell's DoFs in ascending order (the order a sparse matrix row takes additions fastest),
        // and where each local DoF stands in it (local DoF i is sorted_dofs(c)[positions(c)[i]]).
        const types::global_dof_index *sorted_dofs(const std::size_t c) const
        {
          return &sorted_dof_indices[c * dofs_per_cell];
        }
        const unsigned short *positions(const std::size_t c) const { return &sorted_position[c * dofs_per_cell]; }

      private:
        std::vector<Tensor<1, 3>>            gradients;
        std::vector<double>                  JxW_values;
        std::vector<types::global_dof_index> sorted_dof_indices;
        std::vector<unsigned short>          sorted_position;
      };

      // Per cell: whether its part goes through the constraints (a constrained DoF; every cell of a
      // distributed tangent, whose rows may be another process's); the rest is added row by row.
      template <typename Algebra>
      std::vector<char> cells_through_constraints(const ReferenceCells &reference, const std::size_t n_cells,
                                                  const AffineConstraints<double> &constraints)
      {
        std::vector<char> through(n_cells, !std::is_same_v<Algebra, SerialAlgebra>);
        for (std::size_t c = 0; c < n_cells; ++c)
          for (unsigned int i = 0; i < reference.dofs_per_cell && !through[c]; ++i)
            through[c] = constraints.is_constrained(reference.sorted_dofs(c)[i]);
        return through;
      }

      // The converged states of a load ramp (the last three, the unloaded one while fewer levels are
      // known) and the predictors they give for the next level: the secant (the last two states
      // extrapolated; F u1 at the first level) and a quadratic (F u1 + F^2 u2 at the first level, u2
      // the second-order response; F u1 + F^2 c through the first level at the second; then through
      // the last three states).
      template <typename VectorType>
      class LoadPath
      {
      public:
        LoadPath(const VectorType &u1, const VectorType *u2)
          : u1(u1)
          , u2(u2)
          , states(3, u1)
        {
          for (auto &state : states)
            state = 0.;
        }
        void add(const double force, const VectorType &u)
        {
          forces    = {{force, forces[0], forces[1]}};
          states[2] = states[1];
          states[1] = states[0];
          states[0] = u;
          ++levels_known;
        }
        // False at the first level without u2.
        bool has_quadratic() const { return levels_known > 0 || u2 != nullptr; }
        void predict(const double x, VectorType &secant, VectorType &quadratic) const
        {
          const double c = forces[0], b = forces[1], a = forces[2];
          if (levels_known == 0)
            {
              secant = 0.;
              secant.add(x, u1);
              quadratic = secant;
              if (u2 != nullptr)
                quadratic.add(x * x, *u2);
              return;
            }
          secant = quadratic = states[0];
          secant.sadd(1. + (x - c) / (c - b), -(x - c) / (c - b), states[1]);
          if (levels_known == 1)
            {
              const double s = x / c;
              quadratic.sadd(s * s, x * (1. - s), u1);
              return;
            }
          quadratic *= (x - a) * (x - b) / ((c - a) * (c - b));
          quadratic.add((x - a) * (x - c) / ((b - a) * (b - c)), states[1], (x - b) * (x - c) / ((a - b) * (a - c)),
                        states[2]);
        }

      private:
        const VectorType       &u1;
        const VectorType       *u2;
        std::vector<VectorType> states;           // newest first
        std::array<double, 3>   forces{};         // [N], theirs
        unsigned int            levels_known = 0; // converged levels so far
      };

      // |x - y| (l2).
      template <typename VectorType>
      double l2_distance(const VectorType &x, const VectorType &y)
      {
        VectorType difference(x);
        difference -= y;
        return difference.l2_norm();
      }

      template <typename Algebra>
      class LargeDeformationSolve
      {
      public:
        using VectorType = typename Algebra::Vector;

        LargeDeformationSolve(const SpaceView<Algebra> &space, const MaterialParameters &material,
                              const ModeParameters &modes, HyperelasticLaw law);

        // The dead load F * load ramped from 0 to ramp.force_limit: 'load' is a condensed unit patch
        // load W_v d (zero on constrained DoFs), which also reads the felt displacement d^T W_v^T u.
        // The curve's exact second-order estimate from the linear response u1 (curve.estimate_exact,
        // estimate_seconds) and Psi3's check against finite differences of the stored energy along
        // t u1 (curve.cubic_term_check).
        // Each level starts from the last converged one; a level Newton cannot reach (an inverted
        // element at every step length of the line search, a tangent that is not positive definite,
        // no convergence) is retried with half the increment, up to ramp.max_halvings; then the curve
        // stops with stop_reason and force_reached. Newton's relative residuals go to 'log', one line
        // per level.
        ValidityCurve ramp_load(const VectorType &load, const LoadRamp &ramp, const std::function<void(std::string)> &log);

        // What the solves cost: factorizations, CG iterations, assemblies (with the tangent and without).
        struct Counts
        {
          unsigned int factorizations = 0, cg_solves = 0, cg_iterations = 0, tangent_assemblies = 0,
                       residual_assemblies = 0;
          double assembly_seconds = 0., solve_seconds = 0.; // [s] assemblies; factorizations and CG
        } counts;

      private:
        // rhs = force * load - f_int(u) on the free DoFs, the potential energy (stored minus the load's
        // work); the tangent too when with_tangent. False when some quadrature point has det F <= 0
        // on any process (then rhs, energy and the tangent are not to be used).
        bool assemble(const VectorType &u, double force, const VectorType &load, bool with_tangent);
        bool assemble_at(const VectorType &u, double force, const VectorType &load,
                         bool with_tangent); // assemble without its timer
        // The tangent at u = 0 (K: the space's own where it has one, else assembled) and rhs = load.
        void tangent_at_rest(const VectorType &load);
        // This process's cells' share of assemble_at (before the exchange); false at det F <= 0.
        bool assemble_cells(const VectorType &u_read, bool with_tangent, double &local_energy);
        struct LevelOutcome
        {
          bool                converged = false;
          std::vector<double> residuals; // |R| / |f| per iteration
          double              felt_error = 0.; // at the last iterate: |u1^T R| / |d| (LoadRamp::felt_tolerance)
          std::string         failure;
        };
        // Newton from the predictor (from u, the last converged state, where it inverts an element) to
        // the level 'force'; u is updated only when converged. linear_response: u1 = K^-1 load, the
        // felt displacement's adjoint for the convergence test.
        LevelOutcome solve_level(VectorType &u, double force, const VectorType &load, const VectorType &linear_response,
                                 const VectorType &predictor, const LoadRamp &ramp,
                                 const std::function<void(std::string)> &log);
        // tangent^-1 rhs into du; false (and 'failure') when the tangent is not positive definite.
        // With space.use_cg, CG preconditioned by the last factorization (K's, the space's, until a
        // tangent is factorized) to |rhs - tangent du| <= tolerance |rhs|; the tangent is factorized
        // (and preconditions from then on) only where CG stalls or meets negative curvature.
        bool solve_tangent(VectorType &du, std::string &failure, double tolerance = 1e-12);
        bool solve_tangent_system(VectorType &du, std::string &failure, double tolerance); // untimed
        bool preconditioned_cg(VectorType &du, double tolerance);
        // curve.estimate_exact, from u1 = K^-1 load (c2 = -3 Psi3(u1)). Returns the step h [N] of the
        // finite differences along t u1: the largest displacement gradient of h u1 is 1e-3, where the
        // expansion's cubic and quartic terms stand well above the rounding of the energy's quadratic
        // one (1e-3 and 1e-6 of it) and the orders left out are negligible; whatever the force limit (a
        // step from it, tried first, met only rounding at a limit of 1e-3 N).
        double estimate_second_order(const VectorType &u1, ValidityCurve &curve);
        // The stored energy and rhs = -f_int along +-t u1 at t = h, 2 h, 3 h, assembled once for both
        // uses: the odd parts of the energy check Psi3, the even parts give grad Psi3 and Psi4.
        struct ResponseSamples
        {
          bool                    inside = false; // no element inverted at any sample
          double                  h      = 0.;    // [N], quartered from the step asked for where one did
          std::array<double, 3>   odd_energy{}, even_energy{}; // (g(t u1) -+ g(-t u1)) / 2 at t = h, 2 h, 3 h
          std::vector<VectorType> even_rhs;
        };
        // The samples at the step h, quartered until no element inverts (at most 7 times).
        ResponseSamples sample_along_response(const VectorType &u1, double h);
        // The samples at t = h, 2 h, 3 h into 'samples'; false where an element inverts.
        bool sample_at_steps(const VectorType &u1, double h, ResponseSamples &samples);
        // curve.cubic_term_check: Psi3 (from curve.estimate_exact) against the odd part's Richardson
        // extrapolation.
        static void check_cubic_term(const ResponseSamples &samples, ValidityCurve &curve);
        // curve.estimate_third_order and its check from the samples; 'tangent' must still be K (at u = 0).
        // Also the second-order response u2 (u(F) = F u1 + F^2 u2 + O(F^3)) into 'u2'; false where the
        // samples could not give it.
        bool estimate_third_order(const ResponseSamples &samples, ValidityCurve &curve, VectorType &u2);

        const SpaceView<Algebra>                   space;
        const MaterialParameters                   material;
        const ModeParameters                       modes;
        const double                               mu, lambda;
        const HyperelasticLaw                      law;
        // Built once: every residual and tangent assembly walks the same cells and element.
        const std::vector<DoFHandler<3>::active_cell_iterator> owned_cells;
        const VectorElementDofs                                element_dofs;
        const ReferenceCells                                   reference;
        using CellIterator = typename std::vector<DoFHandler<3>::active_cell_iterator>::const_iterator;
        std::vector<double>                                    cell_energy;   // per owned cell, at the last assembly
        const std::vector<char>                                through_constraints; // per owned cell
        typename Algebra::Matrix                   tangent;
        VectorType                                 rhs;
        double                                     energy = 0.; // [J]
        std::unique_ptr<typename Algebra::Inverse> tangent_factor; // the last factorized tangent
      };

      template <typename Algebra>
      LargeDeformationSolve<Algebra>::LargeDeformationSolve(const SpaceView<Algebra> &space, const MaterialParameters &material,
                                                            const ModeParameters &modes, const HyperelasticLaw law)
        : space(space)
        , material(material)
        , modes(modes)
        , mu(lame_constants(material)[0])
        , lambda(lame_constants(material)[1])
        , law(law)
        , owned_cells(locally_owned_cells(space.dof_handler))
        , element_dofs(space.dof_handler.get_fe())
        , reference(owned_cells, space.mapping, space.dof_handler.get_fe(), space.quadrature, element_dofs.dof)
        , cell_energy(owned_cells.size())
        , through_constraints(cells_through_constraints<Algebra>(reference, owned_cells.size(), space.constraints))
      {
        tangent.reinit(space.sparsity);
        rhs = space.owned_layout;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::assemble(const VectorType &u, const double force, const VectorType &load,
                                           const bool with_tangent)
      {
        Timer timer;
        const bool valid = assemble_at(u, force, load, with_tangent);
        counts.assembly_seconds += timer.wall_time();
        return valid;
      }

      template <typename Algebra>
      void LargeDeformationSolve<Algebra>::tangent_at_rest(const VectorType &load)
      {
        if (space.stiffness == nullptr)
          {
            ++counts.tangent_assemblies;
            assemble(space.owned_layout, 1., load, true);
            return;
          }
        tangent.copy_from(*space.stiffness);
        rhs    = load;
        energy = 0.;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::assemble_at(const VectorType &u, const double force, const VectorType &load,
                                                       const bool with_tangent)
      {
        rhs = 0.;
        if (with_tangent)
          tangent = 0.;
        double     local_energy = 0.;
        const bool valid        = assemble_cells(readable(space, u), with_tangent, local_energy);
        // Every process exchanges what it added to others' rows, valid or not: a collective step.
        if (with_tangent)
          tangent.compress(VectorOperation::add);
        rhs.compress(VectorOperation::add);
        const MPI_Comm comm = communicator(space.dof_handler);
        if (Utilities::MPI::min(int(valid), comm) == 0)
          return false;
        energy = Utilities::MPI::sum(local_energy, comm);
        rhs.add(force, load);
        energy -= force * (load * u);
        return true;
      }

      // What a thread needs to assemble a cell of the residual and the tangent (WorkStream's scratch:
      // copied once per thread).
      struct NonlinearScratch
      {
        explicit NonlinearScratch(const unsigned int n_scalar, const unsigned int dofs_per_cell)
          : u(dofs_per_cell)
          , work(n_scalar)
          , blocks(9 * n_scalar * n_scalar)
        {}
        std::vector<double>       u;      // the cell's DoF values
        std::vector<Tensor<1, 3>> work;   // per scalar shape function
        std::vector<double>       blocks; // add_tangent's 3 x 3 blocks
      };

      // A cell's part: its rows and columns in the order of its DoFs' global indices. Added by one
      // thread at a time in the cells' order, so each entry gets its sums in an order fixed by the
      // mesh, not by which thread ends first. (Colours of cells sharing no row, each colour added on
      // every thread at once, were slower, docs/performance.md: a colour's cells are spread over the
      // whole matrix, while consecutive cells in their order share rows in cache.)
      struct NonlinearCellPart
      {
        explicit NonlinearCellPart(const unsigned int dofs_per_cell)
          : K(dofs_per_cell, dofs_per_cell)
          , rhs(dofs_per_cell)
          , dof_indices(dofs_per_cell)
        {}
        FullMatrix<double>                   K;
        Vector<double>                       rhs;
        std::vector<types::global_dof_index> dof_indices;
        std::size_t                          cell   = 0; // in owned_cells
        double                               energy = 0.;
        bool                                 valid  = false; // false: an inverted element, or skipped after one
      };

      // The cells on deal.II's threads (WorkStream), as the linear assembly: the tangent assemblies
      // are most of a validity contact's time (docs/performance.md).
      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::assemble_cells(const VectorType &u_read, const bool with_tangent,
                                                          double &local_energy)
      {
        const auto        &fe            = space.dof_handler.get_fe();
        const unsigned int dofs_per_cell = fe.n_dofs_per_cell();
        const auto        &component     = element_dofs.component;
        const auto        &scalar        = element_dofs.scalar;
        const auto        &dof           = element_dofs.dof;
        const unsigned int n_scalar      = dof.size();
        std::atomic<bool>  inverted{false};

        const auto worker = [&](const CellIterator &cell, NonlinearScratch &scratch, NonlinearCellPart &part) {
            part.valid = false;
            if (inverted.load(std::memory_order_relaxed))
              return; // the assembly has failed: the rest is not needed
            const std::size_t c = part.cell = cell - owned_cells.cbegin();
            const unsigned short *position = reference.positions(c);
            part.dof_indices.assign(reference.sorted_dofs(c), reference.sorted_dofs(c) + dofs_per_cell);
            for (unsigned int i = 0; i < dofs_per_cell; ++i)
              scratch.u[i] = u_read(part.dof_indices[position[i]]);
            part.rhs    = 0.;
            part.energy = 0.;
            if (with_tangent)
              std::fill(scratch.blocks.begin(), scratch.blocks.end(), 0.);
            for (unsigned int q = 0; q < reference.n_q; ++q)
              {
                const Tensor<1, 3> *g = reference.gradients_at(c, q);
                Tensor<2, 3>        grad_u; // grad_u[i][j] = d u_i / d X_j
                for (unsigned int a = 0; a < n_scalar; ++a)
                  for (unsigned int comp = 0; comp < 3; ++comp)
                    grad_u[comp] += scratch.u[dof[a][comp]] * g[a];
                if (!(determinant(identity + grad_u) > 0.))
                  {
                    inverted = true; // an inverted (or degenerate) element: no stress is defined
                    return;
                  }
                const StressAtPoint stress(law, mu, lambda, grad_u);
                const double        JxW = reference.JxW(c, q);
                part.energy += stress.energy() * JxW;
                for (unsigned int i = 0; i < dofs_per_cell; ++i)
                  part.rhs(position[i]) -= stress.stress()[component[i]] * g[scalar[i]] * JxW;
                if (with_tangent)
                  stress.add_tangent(g, n_scalar, JxW, scratch.work, scratch.blocks);
              }
            if (with_tangent)
              scatter_tangent_blocks(scratch.blocks, dof, position, part.K);
            part.valid = true;
        };
        const auto copier = [&](const NonlinearCellPart &part) {
            if (!part.valid)
              return;
            cell_energy[part.cell] = part.energy;
            if (through_constraints[part.cell])
              {
                if (with_tangent)
                  space.constraints.distribute_local_to_global(part.K, part.rhs, part.dof_indices, tangent, rhs);
                else
                  space.constraints.distribute_local_to_global(part.rhs, part.dof_indices, rhs);
                return;
              }
            // No constraint to resolve (serial): the rows straight into the matrix, columns ascending.
            if constexpr (std::is_same_v<Algebra, SerialAlgebra>)
              {
                for (unsigned int i = 0; i < dofs_per_cell; ++i)
                  rhs(part.dof_indices[i]) += part.rhs(i);
                if (with_tangent)
                  assembly::add_sorted_cell_matrix(part.dof_indices, part.K, tangent);
              }
        };
        const NonlinearScratch  scratch(n_scalar, dofs_per_cell);
        const NonlinearCellPart part(dofs_per_cell);
        WorkStream::run(owned_cells.cbegin(), owned_cells.cend(), worker, copier, scratch, part);
        // The energy summed in the cells' order, whichever thread added which cell.
        for (const double e : cell_energy)
          local_energy += e;
        if (inverted)
          return false;

        FullMatrix<double>                   cell_K(dofs_per_cell, dofs_per_cell);
        Vector<double>                       cell_rhs(dofs_per_cell), cell_u(dofs_per_cell);
        std::vector<types::global_dof_index> dof_indices(dofs_per_cell);
        // Elastic supports are linear springs on the reference faces: force k u, stiffness k.
        for (const auto &face : space.elastic_faces)
          {
            assembly::elastic_face_matrix(space.mapping, fe, face, cell_K);
            face.cell->get_dof_indices(dof_indices);
            for (unsigned int i = 0; i < dofs_per_cell; ++i)
              cell_u(i) = u_read(dof_indices[i]);
            cell_K.vmult(cell_rhs, cell_u);
            local_energy += 0.5 * (cell_u * cell_rhs);
            cell_rhs *= -1.;
            if (with_tangent)
              space.constraints.distribute_local_to_global(cell_K, cell_rhs, dof_indices, tangent, rhs);
            else
              space.constraints.distribute_local_to_global(cell_rhs, dof_indices, rhs);
          }
        return true;
      }

      // CG on the tangent, preconditioned by the last factorization: while the part is near its linear
      // state the tangent is close to K, so a few iterations reach the tolerance. False where it stalls
      // (more than 40 iterations, or still above 1e-3 after 10) or meets a direction of non-positive
      // curvature (the caller factorizes, which tells a tangent that is not positive definite).
      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::preconditioned_cg(VectorType &du, const double tolerance)
      {
        typename Algebra::Inverse *preconditioner = tangent_factor ? tangent_factor.get() : space.linear_factorization;
        if (!space.use_cg || preconditioner == nullptr)
          return false;
        ++counts.cg_solves;
        VectorType r(rhs), z(rhs), p(rhs), Ap(rhs);
        du                    = 0.;
        const double b_norm   = rhs.l2_norm();
        const auto   precondition = [&] {
          z = r;
          preconditioner->solve_block(z.begin(), 1);
        };
        precondition();
        p         = z;
        double rz = r * z;
        for (unsigned int iteration = 1; iteration <= 40; ++iteration)
          {
            ++counts.cg_iterations;
            tangent.vmult(Ap, p);
            const double pAp = p * Ap;
            if (!(pAp > 0.))
              return false;
            const double alpha = rz / pAp;
            du.add(alpha, p);
            r.add(-alpha, Ap);
            const double relative = r.l2_norm() / b_norm;
            if (relative <= tolerance)
              return true;
            if (iteration >= 10 && relative > 1e-3)
              return false;
            precondition();
            const double rz_next = r * z;
            p.sadd(rz_next / rz, z);
            rz = rz_next;
          }
        return false;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::solve_tangent(VectorType &du, std::string &failure, const double tolerance)
      {
        Timer      timer;
        const bool solved = solve_tangent_system(du, failure, tolerance);
        counts.solve_seconds += timer.wall_time();
        return solved;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::solve_tangent_system(VectorType &du, std::string &failure, const double tolerance)
      {
        if (preconditioned_cg(du, tolerance))
          {
            space.constraints.distribute(du);
            return true;
          }
        ++counts.factorizations;
        tangent_factor = factorize_tangent(tangent, modes);
        if (!tangent_factor)
          {
            failure = "the tangent stiffness is not positive definite (a limit point: buckling, snap-through "
                      "or a material instability)";
            return false;
          }
        du = rhs;
        tangent_factor->solve_block(du.begin(), 1);
        space.constraints.distribute(du);
        return true;
      }

      template <typename Algebra>
      double LargeDeformationSolve<Algebra>::estimate_second_order(const VectorType &u1, ValidityCurve &curve)
      {
        Timer        timer;
        double       largest_gradient = 0.;
        const double psi3             = cubic_energy(space, material, law, u1, &largest_gradient);
        curve.estimate_seconds += timer.wall_time();
        curve.estimate_exact.c2 = -3. * psi3;
        curve.estimate_exact.validity_force = series_validity_forces(curve.linear_compliance, curve.estimate_exact.c2);
        return largest_gradient > 0. ? 1e-3 / largest_gradient : curve.force_limit / 100.;
      }

      template <typename Algebra>
      typename LargeDeformationSolve<Algebra>::ResponseSamples
      LargeDeformationSolve<Algebra>::sample_along_response(const VectorType &u1, double h)
      {
        ResponseSamples samples;
        samples.even_rhs.assign(3, u1);
        for (unsigned int attempt = 0; attempt < 8 && !samples.inside; ++attempt, h /= 4.)
          samples.inside = sample_at_steps(u1, h, samples);
        return samples;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::sample_at_steps(const VectorType &u1, const double h,
                                                           ResponseSamples &samples)
      {
        samples.h = h;
        for (unsigned int i = 0; i < 3; ++i)
          {
            samples.odd_energy[i] = samples.even_energy[i] = 0.;
            samples.even_rhs[i]                            = 0.;
            for (const double sign : {1., -1.})
              {
                VectorType u(u1);
                u *= sign * (i + 1) * h;
                if (!assemble(u, 0., u1, false))
                  return false;
                samples.odd_energy[i] += sign * 0.5 * energy;
                samples.even_energy[i] += 0.5 * energy;
                samples.even_rhs[i].add(0.5, rhs);
              }
          }
        return true;
      }

      // The odd part of the stored energy along t u1, o(t) = t^3 Psi3 + t^5 Psi5 + ... (the elastic
      // supports' quadratic energy cancels), at t = h and 2 h: Richardson's (32 o(h) - o(2 h)) / (24 h^3).
      template <typename Algebra>
      void LargeDeformationSolve<Algebra>::check_cubic_term(const ResponseSamples &samples, ValidityCurve &curve)
      {
        if (!samples.inside)
          return; // stays -1: not computed
        const double psi3              = -curve.estimate_exact.c2 / 3.;
        const double h                 = samples.h;
        const double finite_difference = (32. * samples.odd_energy[0] - samples.odd_energy[1]) / (24. * h * h * h);
        curve.cubic_term_check = std::abs(finite_difference - psi3) / std::max(std::abs(psi3), 1e-300);
      }

      // The weights on e(h), e(2 h), e(3 h) of the t^2 and t^4 coefficients of an even series
      // e(t) = x t^2 + y t^4 + z t^6 (+ O(t^8)): the quadratic e / s in s = (t / h)^2 through s = 1, 4, 9
      // by divided differences, applied to each unit sample.
      std::array<std::array<double, 3>, 2> even_series_weights()
      {
        std::array<std::array<double, 3>, 2> weights{};
        for (unsigned int i = 0; i < 3; ++i)
          {
            std::array<double, 3> e{};
            e[i]                 = 1.;
            const double f1 = e[0], f4 = e[1] / 4., f9 = e[2] / 9.;
            const double d1 = (f4 - f1) / 3., d2 = (f9 - f4) / 5., z = (d2 - d1) / 8., y = d1 - 5. * z;
            weights[0][i] = f1 - y - z; // x h^2
            weights[1][i] = y;          // y h^4
          }
        return weights;
      }

      template <typename Algebra>
      bool LargeDeformationSolve<Algebra>::estimate_third_order(const ResponseSamples &samples, ValidityCurve &curve,
                                                                VectorType &u2)
      {
        // d(F) = c1 F + c2 F^2 + c3 F^3: K u2 = -grad Psi3(u1) = -g2, K u3 = -2 B(u1, u2) - grad Psi4(u1)
        // (grad Psi3(u) = B(u, u)), and u1^T B(u1, u2) = g2^T u2 = -u2^T K u2, Euler's theorem for
        // Psi4: c3 = u1^T K u3 = 2 u2^T K u2 - 4 Psi4(u1). g2 and Psi4(u1) from the even parts along
        // t u1 (the elastic supports' energy is quadratic: it is in the t^2 terms only).
        Timer      timer;
        const auto weights = even_series_weights();
        curve.estimate_third_order.c2 = curve.estimate_exact.c2;
        if (!samples.inside)
          {
            curve.estimate_third_order.c3 = std::numeric_limits<double>::quiet_NaN();
            curve.estimate_third_order.validity_force.fill(std::numeric_limits<double>::quiet_NaN());
            return false;
          }
        const double h = samples.h;
        const auto  &even_energy = samples.even_energy;
        const auto  &even_rhs    = samples.even_rhs;
        double quadratic = 0., psi4 = 0.;
        rhs              = 0.; // -g2
        for (unsigned int i = 0; i < 3; ++i)
          {
            quadratic += weights[0][i] * even_energy[i] / (h * h);
            psi4 += weights[1][i] * even_energy[i] / std::pow(h, 4);
            rhs.add(weights[0][i] / (h * h), even_rhs[i]);
          }
        curve.quadratic_term_check = std::abs(2. * quadratic - curve.linear_compliance) / curve.linear_compliance;

        const VectorType minus_g2(rhs);
        u2 = rhs;
        std::string failure;
        AssertThrow(solve_tangent(u2, failure), ExcMessage("The validity analysis' third-order term: " + failure));
        curve.estimate_third_order.c3 = 2. * (u2 * minus_g2) - 4. * psi4;
        curve.estimate_third_order.validity_force =
          series_validity_forces(curve.linear_compliance, curve.estimate_third_order.c2, curve.estimate_third_order.c3);
        curve.estimate_seconds += timer.wall_time();
        return true;
      }

      template <typename Algebra>
      typename LargeDeformationSolve<Algebra>::LevelOutcome LargeDeformationSolve<Algebra>::solve_level(VectorType &u, const double force,
                                                                             const VectorType &load,
                                                                             const VectorType &linear_response,
                                                                             const VectorType &predictor,
                                                                             const LoadRamp &ramp,
                                                                             const std::function<void(std::string)> &log)
      {
        LevelOutcome   outcome;
        const double   load_norm = force * load.l2_norm();
        VectorType trial(predictor), du(u);
        ++counts.tangent_assemblies;
        if (!assemble(trial, force, load, true)) // the predictor inverts an element: from the last level
          {
            trial = u;
            ++counts.tangent_assemblies;
            AssertThrow(assemble(trial, force, load, true), ExcInternalError()); // a converged state is valid
          }
        double residual = rhs.l2_norm() / load_norm;
        // The residual over the load; or the felt displacement's error (where the residual's norm is
        // held up by stiff components that barely move the point pressed: one Newton iteration from
        // the quadratic predictor leaves 1e-7 to 7e-6 of the load on the default scene's ribs, and
        // 3e-9 to 3e-8 of the felt displacement).
        // Once per iterate (two collective dot products under MPI).
        const auto converged = [&]() {
          outcome.felt_error = std::abs(linear_response * rhs) / std::abs(load * trial);
          return residual <= ramp.tolerance || outcome.felt_error <= ramp.felt_tolerance;
        };
        bool at_solution = converged();
        for (unsigned int iteration = 0;; ++iteration)
          {
            outcome.residuals.push_back(residual);
            if (at_solution)
              {
                u                 = trial;
                outcome.converged = true;
                return outcome;
              }
            if (iteration == ramp.max_iterations)
              {
                outcome.failure = "no convergence in " + std::to_string(ramp.max_iterations) + " Newton iterations";
                return outcome;
              }
            // An inexact Newton step, solved to a hundredth of the residual: the error it leaves is
            // smaller than the quadratic term's from r ~ 1e-2 down (and 1e-12 at most, the rounding
            // floor). Never tighter than needed to leave a hundredth of the level's tolerance: near
            // the solution the step's last CG iterations would only polish digits the next residual
            // does not show (that error, at most 1e-2 tolerance, stays below what the convergence
            // test and the quadratic rate r_k+1 / r_k^2 look at).
            const double forcing = std::max(std::clamp(1e-2 * residual, 1e-12, 1e-4), 1e-2 * ramp.tolerance / residual);
            if (!solve_tangent(du, outcome.failure, forcing))
              return outcome;
            // Backtracking: halve the step until every element keeps det F > 0 and the potential energy
            // has decreased enough along Newton's direction (Armijo, c = 1e-4; the direction descends
            // it while the tangent is positive definite), or the residual has (near the solution, where
            // the energy's change drowns in rounding). The residual alone is a poor guide far from the
            // solution: a slender part's linear predictor stretches it, and the axial force that
            // follows dwarfs the load, though the energy has gone down.
            const VectorType start(trial);
            const double         start_energy = energy, slope = -(rhs * du);
            bool                 accepted = false, inverted = false;
            for (double step = 1.; step >= 1. / 1024.; step /= 2.)
              {
                trial = start;
                trial.add(step, du);
                ++counts.residual_assemblies;
                if (!assemble(trial, force, load, false))
                  {
                    inverted = true;
                    continue;
                  }
                const double trial_residual = rhs.l2_norm() / load_norm;
                if (energy <= start_energy + 1e-4 * step * slope || trial_residual < (1. - 1e-4 * step) * residual)
                  {
                    residual = trial_residual;
                    accepted = true;
                    break;
                  }
              }
            // The tangent at the new iterate, unless it is the solution.
            if (accepted)
              at_solution = converged();
            if (accepted && !at_solution)
              {
                ++counts.tangent_assemblies;
                assemble(trial, force, load, true);
              }
            if (log)
              {
                std::ostringstream line;
                line << "validity:   F = " << std::setprecision(4) << force << " N, Newton iteration " << iteration + 1
                     << ": |R|/|f| = " << std::scientific << std::setprecision(2) << residual
                     << ", felt displacement to " << outcome.felt_error << (accepted ? "" : " (line search failed)");
                log(line.str());
              }
            if (!accepted)
              {
                outcome.failure = inverted ? "an element inverts (det F <= 0) at every step length of the line search" :
                                             "the line search found no step that lowers the residual";
                return outcome;
              }
          }
      }

      template <typename Algebra>
      ValidityCurve LargeDeformationSolve<Algebra>::ramp_load(const VectorType &load, const LoadRamp &ramp,
                                                     const std::function<void(std::string)> &log)
      {
        Timer          timer;
        ValidityCurve  curve;
        VectorType u(space.owned_layout), du(u);
        tangent_factor.reset(); // another contact's tangent: K's factorization preconditions better
        curve.material    = law_name(law);
        curve.force_limit = ramp.force_limit;

        // The linear felt compliance from the tangent at the reference state (linear elasticity), and
        // the exact second-order estimate from the same response.
        // The estimate's cost is this solve's and Psi3's integral (K's factorization would give u1 as well).
        std::string failure;
        tangent_at_rest(load);
        Timer solve_timer;
        AssertThrow(solve_tangent(du, failure), ExcMessage("The validity analysis: " + failure + " at zero load."));
        curve.estimate_seconds  = solve_timer.wall_time();
        curve.linear_compliance = load * du;
        const double step = estimate_second_order(du, curve);
        Timer        sample_timer;
        const auto   samples = sample_along_response(du, step);
        curve.estimate_seconds += sample_timer.wall_time();
        check_cubic_term(samples, curve);
        VectorType u2(u);
        const bool has_u2 = estimate_third_order(samples, curve, u2);

        const double first_increment = ramp.force_limit / ramp.load_steps;
        const double least_increment = first_increment / std::pow(2., ramp.max_halvings);
        double       force = 0., increment = first_increment;
        // Each level starts from the quadratic predictor where it stays within a tenth of the increment
        // of the secant one, else from the secant (LoadPath). On a smooth curve (the default scene's
        // ribs) one Newton iteration from the quadratic meets the tolerance, where the secant needs
        // two. Where a level fails from the quadratic (on the elastica it overshoots into a state
        // whose tangent is indefinite), that level and the rest start from the secant.
        LoadPath<VectorType> path(du, has_u2 ? &u2 : nullptr);
        bool                 quadratic_usable = true;
        VectorType           secant(u), quadratic(u);
        while (force < ramp.force_limit)
          {
            const double target = std::min(force + increment, ramp.force_limit);
            path.predict(target, secant, quadratic);
            const bool use_quadratic = quadratic_usable && path.has_quadratic() &&
                                       l2_distance(quadratic, secant) <= 0.1 * l2_distance(secant, u);
            const VectorType &predictor = use_quadratic ? quadratic : secant;
            const auto outcome = solve_level(u, target, load, du, predictor, ramp, log);
            std::ostringstream line;
            line << "validity: F = " << std::setprecision(4) << target << " N, Newton |R|/|f|:" << std::scientific
                 << std::setprecision(2);
            for (const double r : outcome.residuals)
              line << ' ' << r;
            if (outcome.converged)
              {
                force = target;
                path.add(force, u);
                curve.forces.push_back(force);
                curve.displacements.push_back(load * u);
                curve.newton_iterations.push_back(outcome.residuals.size() - 1);
                curve.newton_residuals.push_back(outcome.residuals);
                curve.newton_felt_errors.push_back(outcome.felt_error);
                line << " (" << outcome.residuals.size() - 1 << (outcome.residuals.size() == 2 ? " iteration" : " iterations")
                     << " from the " << (use_quadratic ? "quadratic" : "secant") << " predictor, felt displacement to "
                     << outcome.felt_error << ")";
                log(line.str());
                // Back up to the first increment once Newton converges fast again after a cut.
                if (outcome.residuals.size() <= 5)
                  increment = std::min(2. * increment, first_increment);
                continue;
              }
            line << ": " << outcome.failure;
            if (use_quadratic) // the level again from the secant, the increment as it was
              {
                line << " (from the quadratic predictor: again from the secant)";
                log(line.str());
                quadratic_usable = false;
                continue;
              }
            log(line.str());
            increment /= 2.;
            if (increment < least_increment)
              {
                std::ostringstream reason;
                reason << outcome.failure << ", with the load increment cut to " << std::setprecision(3)
                       << 2. * increment << " N beyond " << force << " N";
                curve.stop_reason = reason.str();
                break;
              }
          }
        curve.force_reached = force;
        curve.seconds       = timer.wall_time();
        set_validity_forces(curve);
        return curve;
      }
    } // namespace

    void set_validity_forces(ValidityCurve &curve)
    {
      const auto departure = [&](const std::size_t k) {
        const double compliance = curve.displacements[k] / curve.forces[k];
        return compliance > 0. ? std::abs(curve.linear_compliance / compliance - 1.) :
                                 std::numeric_limits<double>::infinity();
      };
      for (unsigned int level = 0; level < validity_departures.size(); ++level)
        {
          const double wanted = validity_departures[level];
          // Not reached on the curve: beyond the limit, or at most where the part stopped carrying.
          curve.validity_force[level] =
            curve.stop_reason.empty() ? std::numeric_limits<double>::infinity() : curve.force_reached;
          double previous_force = 0., previous_departure = 0.; // the curve starts linear at F = 0
          for (std::size_t k = 0; k < curve.forces.size(); ++k)
            {
              const double d = departure(k);
              if (d >= wanted)
                {
                  curve.validity_force[level] =
                    std::isfinite(d) ? previous_force + (curve.forces[k] - previous_force) * (wanted - previous_departure) /
                                                          (d - previous_departure) :
                                       previous_force;
                  break;
                }
              previous_force     = curve.forces[k];
              previous_departure = d;
            }
        }
    }

    std::array<double, 3> inward_normal(const ContactSurface &display, const unsigned int vertex,
                                        const std::function<double(const meshing::Point3 &)> &outside)
    {
      Tensor<1, 3> normal;
      const auto   point = [&](const unsigned int v) {
        return Point<3>(display.vertices[v][0], display.vertices[v][1], display.vertices[v][2]);
      };
      for (unsigned int k = display.vertex_triangle_offsets[vertex]; k < display.vertex_triangle_offsets[vertex + 1]; ++k)
        {
          const auto &t = display.triangles[display.vertex_triangles[k]];
          normal += cross_product_3d(point(t[1]) - point(t[0]), point(t[2]) - point(t[0])); // twice the area
        }
      AssertThrow(normal.norm() > 0., ExcMessage("Display vertex " + std::to_string(vertex) + " has no triangle."));
      normal /= normal.norm();
      // A tenth of the local triangle size away on either side: the side inside the part is the one
      // less far outside the mesh.
      const double step  = 0.1 * std::sqrt(3. * display.vertex_area[vertex]);
      const auto   moved = [&](const double sign) {
        const Point<3> x = point(vertex) + sign * step * normal;
        return outside({{x[0], x[1], x[2]}});
      };
      const double sign = moved(-1.) <= moved(1.) ? -1. : 1.;
      return {{sign * normal[0], sign * normal[1], sign * normal[2]}};
    }

    double modal_second_order(const ModalView &modal, const ModalSpaceResult &result, const unsigned int vertex,
                              const std::array<double, 3> &direction, std::vector<double> *q_out)
    {
      std::vector<double> q = modal.load(vertex, direction);
      for (unsigned int i = 0; i < q.size(); ++i)
        q[i] *= static_gain(result.eigenvalues[i]);
      const double c2 = -3. * modal.cubic.value(q);
      if (q_out)
        *q_out = std::move(q);
      return c2;
    }

    namespace
    {
      // The map's entries of a vertex: infinity (not reached) as validity_not_reached.
      void set_map_entry(ModalSpaceResult &result, const unsigned int vertex, const std::array<double, 3> &forces)
      {
        for (unsigned int k = 0; k < 3; ++k)
          result.validity_force[3 * std::size_t(vertex) + k] = std::isfinite(forces[k]) ? forces[k] : validity_not_reached;
      }

      // "1.2 / 5.9 / 11 N" for forces where infinity reads "not reached".
      std::string forces_text(const std::array<double, 3> &forces)
      {
        std::ostringstream out;
        out << std::setprecision(3);
        for (unsigned int k = 0; k < 3; ++k)
          {
            if (std::isfinite(forces[k]))
              out << forces[k];
            else
              out << "not reached";
            out << (k < 2 ? " / " : " N");
          }
        return out.str();
      }
    } // namespace

    void estimate_validity_map(const ContactSurface &display, const std::function<ModalView()> &make_modal,
                               ModalSpaceResult &result, const std::function<void(std::string)> &summarize)
    {
      const unsigned int nv = display.n_vertices();
      result.validity_force.assign(3 * std::size_t(nv), 0.);
      if (result.n_rigid_body_modes > 0)
        {
          result.validity_left_out = "the supports leave rigid motions free (" + result.free_motions +
                                     "), which a dead load would accelerate without bound";
          summarize("validity map left out: " + result.validity_left_out);
          return;
        }
      const ModalView     modal = make_modal();
      Timer               timer;
      std::vector<double> positions(3 * std::size_t(nv)), normals(3 * std::size_t(nv));
      std::vector<unsigned int> triangles;
      for (unsigned int v = 0; v < nv; ++v)
        std::copy(display.vertices[v].begin(), display.vertices[v].end(), &positions[3 * std::size_t(v)]);
      for (const auto &triangle : display.triangles)
        triangles.insert(triangles.end(), triangle.begin(), triangle.end());
      mrt::area_weighted_normals(positions.data(), nv, triangles.data(), display.triangles.size(), normals.data());
      unsigned int count = 0, lowest = 0;
      for (unsigned int v = 0; v < nv; ++v)
        if (result.felt_stiffness[v] > 0.)
          {
            const std::array<double, 3> inward = {{-normals[3 * v], -normals[3 * v + 1], -normals[3 * v + 2]}};
            const double                c1     = 1. / result.felt_stiffness[v];
            set_map_entry(result, v, series_validity_forces(c1, modal_second_order(modal, result, v, inward)));
            ++count;
            if (display.region[v] == result.index &&
                (display.region[lowest] != result.index || result.validity_force[3 * v] < result.validity_force[3 * lowest]))
              lowest = v;
          }
      result.validity_estimated_contacts  = count;
      result.validity_tensor_seconds      = modal.cubic.seconds;
      result.validity_seconds_per_contact = count ? timer.wall_time() / count : 0.;
      std::ostringstream line;
      line << "validity map: the second-order estimate at " << count << " contacts (" << result.eigenvalues.size()
           << "-mode cubic term in " << std::setprecision(3) << modal.cubic.seconds << " s, then "
           << 1e6 * result.validity_seconds_per_contact << " us per contact)";
      if (display.region[lowest] == result.index && result.validity_force[3 * lowest] > 0.)
        line << "; the lowest 1 % validity force of its region " << result.validity_force[3 * lowest]
             << " N at display vertex " << lowest << " (" << display.vertices[lowest][0] << ", "
             << display.vertices[lowest][1] << ", " << display.vertices[lowest][2] << ") m";
      summarize(line.str());
    }

    template <typename Algebra>
    void analyse_validity(const SpaceView<Algebra> &space, const SceneParameters &scene, const SpaceTask &task,
                          const ContactSurface &display,
                          const std::function<typename Algebra::Vector(unsigned int, const std::array<double, 3> &)> &patch_load,
                          const std::function<double(const meshing::Point3 &)> &outside,
                          const std::function<std::optional<ModalView>()> &make_modal, ModalSpaceResult &result, const std::function<void(std::string)> &log,
                          const std::function<void(std::string)> &summarize)
    {
      if (result.n_rigid_body_modes > 0)
        {
          summarize("validity analysis left out: the supports leave rigid motions free (" + result.free_motions +
              "), which a dead load would accelerate without bound");
          return;
        }
      const auto &contact = scene.contact;
      LoadRamp    ramp;
      ramp.force_limit = contact.force_limit;
      ramp.load_steps  = contact.validity_load_steps;
      const auto            law = validity_law(scene);
      LargeDeformationSolve<Algebra> solve(space, scene.material, scene.modes, law);
      const auto            modal = make_modal();
      for (const unsigned int vertex : task.validity_vertices)
        {
          const auto direction =
            contact.validity_direction ? *contact.validity_direction : inward_normal(display, vertex, outside);
          std::ostringstream heading;
          heading << "validity: display vertex " << vertex << ", pressed along (" << std::setprecision(3)
                  << direction[0] << ", " << direction[1] << ", " << direction[2] << ") up to " << ramp.force_limit
                  << " N ('Contact/Force limit'), " << law_name(law);
          log(heading.str());
          const auto before = solve.counts;
          auto curve      = solve.ramp_load(patch_load(vertex, direction), ramp, log);
          curve.vertex    = vertex;
          curve.direction = direction;
          std::ostringstream summary;
          summary << "validity: display vertex " << vertex << ": " << curve.forces.size() << " load levels in "
                  << std::fixed << std::setprecision(1) << curve.seconds << " s ("
                  << solve.counts.tangent_assemblies - before.tangent_assemblies << " tangent and "
                  << solve.counts.residual_assemblies - before.residual_assemblies << " residual assemblies, "
                  << solve.counts.factorizations - before.factorizations << " factorizations, "
                  << solve.counts.cg_iterations - before.cg_iterations << " CG iterations in "
                  << solve.counts.cg_solves - before.cg_solves << " solves; assemblies "
                  << solve.counts.assembly_seconds - before.assembly_seconds << " s, solves "
                  << solve.counts.solve_seconds - before.solve_seconds << " s); linear felt compliance holds to 1/5/10 % up to "
                  << std::defaultfloat << forces_text(curve.validity_force);
          if (!curve.stop_reason.empty())
            summary << "; the solve stopped at " << curve.force_reached << " N of " << ramp.force_limit
                    << " N: " << curve.stop_reason;
          summary << "; third-order estimate " << forces_text(curve.estimate_third_order.validity_force)
                  << ", second-order " << forces_text(curve.estimate_exact.validity_force) << " (exact, both "
                  << std::setprecision(2) << curve.estimate_seconds << " s)";
          if (modal)
            {
              std::vector<double> q;
              curve.estimate_modal.c2 = modal_second_order(*modal, result, vertex, direction, &q);
              curve.estimate_modal.validity_force =
                series_validity_forces(curve.linear_compliance, curve.estimate_modal.c2);
              // The tensor against Psi3 of the field it stands for (serial runs: the modes as serial vectors).
              if constexpr (std::is_same_v<Algebra, SerialAlgebra>)
                if (modal->serial_modes)
                  {
                    Vector<double> field(space.dof_handler.n_dofs());
                    for (unsigned int i = 0; i < q.size(); ++i)
                      field.add(q[i], (*modal->serial_modes)[i]);
                    const double direct = cubic_energy(space, scene.material, law, field);
                    curve.modal_cubic_check =
                      std::abs(modal->cubic.value(q) - direct) / std::max(std::abs(direct), 1e-300);
                  }
              summary << ", " << std::setprecision(3) << forces_text(curve.estimate_modal.validity_force) << " (modal)";
              // The map holds the full solve's forces where it pressed along the map's normal.
              if (!result.validity_force.empty() && !contact.validity_direction)
                set_map_entry(result, vertex, curve.validity_force);
            }
          summarize(summary.str());
          result.validity.push_back(std::move(curve));
        }
    }

    template void analyse_validity(const SpaceView<SerialAlgebra> &, const SceneParameters &, const SpaceTask &,
                                   const ContactSurface &,
                                   const std::function<Vector<double>(unsigned int, const std::array<double, 3> &)> &,
                                   const std::function<double(const meshing::Point3 &)> &,
                                   const std::function<std::optional<ModalView>()> &, ModalSpaceResult &,
                                   const std::function<void(std::string)> &, const std::function<void(std::string)> &);
    template void analyse_validity(const SpaceView<DistributedAlgebra> &, const SceneParameters &, const SpaceTask &,
                                   const ContactSurface &,
                                   const std::function<TrilinosWrappers::MPI::Vector(unsigned int, const std::array<double, 3> &)> &,
                                   const std::function<double(const meshing::Point3 &)> &,
                                   const std::function<std::optional<ModalView>()> &, ModalSpaceResult &,
                                   const std::function<void(std::string)> &, const std::function<void(std::string)> &);
  } // namespace nonlinear
} // namespace modal_haptics
