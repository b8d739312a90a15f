// The cubic term Psi3 of the stored energy's expansion about the reference state: on the mesh at a
// displacement (cubic_energy) and on the span of the lowest modes as a tensor (ModalCubicTerm).
#include "nonlinear/large_deformation_solve.h"
#include "nonlinear/hyperelastic_stress.h"

#include "solvers/blas_lapack.h"

#include <deal.II/base/multithread_info.h>
#include <deal.II/base/thread_management.h>
#include <deal.II/base/timer.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/fe_values_extractors.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>

namespace modal_haptics
{
  namespace nonlinear
  {
    using namespace dealii;

    namespace
    {
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

    // Psi3(u) [J], the cubic term of the stored energy's expansion in u about the reference state
    // (the elastic supports are quadratic: none), by the space's quadrature on every process's
    // cells. With H = grad u, eps = sym H, sigma = lambda tr(eps) I + 2 mu eps: St. Venant-Kirchhoff
    // psi3 = 1/2 sigma : (H^T H); the neo-Hookean law adds -lambda tr(eps) tr(eps^2) - 4/3 mu tr(eps^3)
    // (W = lambda/2 (tr E)^2 + mu tr E^2 - lambda tr E tr E^2 - 4/3 mu tr E^3 + O(E^4)).
    // With largest_gradient, also the largest |grad u| (Frobenius) at a quadrature point.
    template <typename Algebra>
    double cubic_energy(const SpaceView<Algebra> &space, const MaterialParameters &material,
                        const HyperelasticLaw law, const typename Algebra::Vector &u,
                        double *largest_gradient)
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

    template double cubic_energy(const SpaceView<SerialAlgebra> &, const MaterialParameters &, HyperelasticLaw,
                                 const Vector<double> &, double *);
    template double cubic_energy(const SpaceView<DistributedAlgebra> &, const MaterialParameters &, HyperelasticLaw,
                                 const TrilinosWrappers::MPI::Vector &, double *);

    namespace
    {
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
  } // namespace nonlinear
} // namespace modal_haptics
