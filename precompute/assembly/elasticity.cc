#include "assembly/elasticity.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values_extractors.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>

#include <algorithm>
#include <numeric>
#include <type_traits>

namespace modal_haptics
{
  using namespace dealii;

  namespace assembly
  {
    void elastic_face_matrix(const Mapping<3> &mapping, const FiniteElement<3> &fe, const ElasticFace &face,
                             FullMatrix<double> &face_K)
    {
      FEFaceValues<3> values(mapping, fe, QGaussSimplex<2>(fe.degree + 1),
                             update_values | update_normal_vectors | update_JxW_values);
      values.reinit(face.cell, face.face);
      const FEValuesExtractors::Vector displacement(0);
      face_K = 0.;
      for (const unsigned int q : values.quadrature_point_indices())
        {
          const Tensor<1, 3> &n = values.normal_vector(q);
          for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
            {
              const Tensor<1, 3> phi_i = values[displacement].value(i, q);
              for (unsigned int j = 0; j < fe.n_dofs_per_cell(); ++j)
                {
                  const Tensor<1, 3> phi_j = values[displacement].value(j, q);
                  const double       normal_part = (phi_i * n) * (phi_j * n);
                  face_K(i, j) += (face.normal_stiffness * normal_part +
                                   face.tangential_stiffness * (phi_i * phi_j - normal_part)) * values.JxW(q);
                }
            }
        }
    }

    CellAssembler::CellAssembler(const MaterialParameters &material, const unsigned int dofs_per_cell)
      : material(material)
      , mu(material.youngs_modulus / (2. * (1. + material.poissons_ratio)))
      , lambda(material.youngs_modulus * material.poissons_ratio /
               ((1. + material.poissons_ratio) * (1. - 2. * material.poissons_ratio)))
      , component(dofs_per_cell)
      , gradient(dofs_per_cell)
      , value(dofs_per_cell)
    {}

    // Each shape function of the vector element is a scalar one, N_i, times a unit vector e_c, so
    // with the component c of i and d of j:
    //   K_ij = int lambda d_c N_i d_d N_j + mu (delta_cd grad N_i . grad N_j + d_d N_i d_c N_j),
    //   M_ij = int rho delta_cd N_i N_j,
    // the strain tensors' inner products written out: a fraction of their cost per pair.
    void CellAssembler::assemble(const FEValues<3> &fe_values, FullMatrix<double> &cell_K, FullMatrix<double> &cell_M,
                                 MassMoments &moments)
    {
      const unsigned int dofs_per_cell = component.size();
      const auto        &fe            = fe_values.get_fe();
      for (unsigned int i = 0; i < dofs_per_cell; ++i)
        component[i] = fe.system_to_component_index(i).first;
      cell_K = 0.;
      cell_M = 0.;
      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double JxW = fe_values.JxW(q);
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            {
              gradient[i] = fe_values.shape_grad(i, q);
              value[i]    = fe_values.shape_value(i, q);
            }
          for (unsigned int i = 0; i < dofs_per_cell; ++i)
            {
              const unsigned int   c      = component[i];
              const Tensor<1, 3>  &grad_i = gradient[i];
              for (unsigned int j = 0; j <= i; ++j)
                {
                  const unsigned int  d      = component[j];
                  const Tensor<1, 3> &grad_j = gradient[j];
                  double              k_ij   = lambda * grad_i[c] * grad_j[d] + mu * grad_i[d] * grad_j[c];
                  if (c == d)
                    {
                      k_ij += mu * (grad_i * grad_j);
                      cell_M(i, j) += material.density * value[i] * value[j] * JxW;
                    }
                  cell_K(i, j) += k_ij * JxW;
                }
            }
          const Point<3> &x = fe_values.quadrature_point(q);
          moments.mass += material.density * JxW;
          moments.first += material.density * JxW * x;
          moments.second += material.density * JxW * outer_product(x, x);
        }
      for (unsigned int i = 0; i < dofs_per_cell; ++i)
        for (unsigned int j = i + 1; j < dofs_per_cell; ++j)
          {
            cell_K(i, j) = cell_K(j, i);
            cell_M(i, j) = cell_M(j, i);
          }
    }

    MassMoments &MassMoments::operator+=(const MassMoments &other)
    {
      mass += other.mass;
      first += other.first;
      second += other.second;
      return *this;
    }

    namespace
    {
      // What a thread needs to assemble a cell (WorkStream's scratch: copied once per thread).
      struct AssemblyScratch
      {
        AssemblyScratch(const Mapping<3> &mapping, const FiniteElement<3> &fe, const Quadrature<3> &quadrature,
                        const MaterialParameters &material)
          : fe_values(mapping, fe, quadrature,
                      update_values | update_gradients | update_quadrature_points | update_JxW_values)
          , assembler(material, fe.n_dofs_per_cell())
        {}
        AssemblyScratch(const AssemblyScratch &other)
          : fe_values(other.fe_values.get_mapping(), other.fe_values.get_fe(), other.fe_values.get_quadrature(),
                      other.fe_values.get_update_flags())
          , assembler(other.assembler)
        {}
        FEValues<3>   fe_values;
        CellAssembler assembler;
      };

      // A cell's part, added by one thread at a time in the cells' order. A cell without a
      // constrained DoF has its rows and columns put in the ascending order of its DoFs by the thread
      // that integrated it, and goes into a serial matrix row by row; through the constraints, the
      // one thread adding took about as long as the others integrating (rib_a of the default scene).
      struct CellContribution
      {
        explicit CellContribution(const unsigned int dofs_per_cell)
          : K(dofs_per_cell, dofs_per_cell)
          , M(dofs_per_cell, dofs_per_cell)
          , sorted_K(dofs_per_cell, dofs_per_cell)
          , sorted_M(dofs_per_cell, dofs_per_cell)
          , dof_indices(dofs_per_cell)
          , sorted_dofs(dofs_per_cell)
          , order(dofs_per_cell)
        {}
        FullMatrix<double>                   K, M, sorted_K, sorted_M;
        std::vector<types::global_dof_index> dof_indices, sorted_dofs;
        std::vector<unsigned int>            order;
        bool                                 through_constraints = true;
        MassMoments                          moments;

        // sorted_* from K, M and dof_indices.
        void sort_by_dof()
        {
          ascending_dof_order(dof_indices, order);
          for (unsigned int i = 0; i < order.size(); ++i)
            {
              sorted_dofs[i] = dof_indices[order[i]];
              for (unsigned int j = 0; j < order.size(); ++j)
                {
                  sorted_K(i, j) = K(order[i], order[j]);
                  sorted_M(i, j) = M(order[i], order[j]);
                }
            }
        }
      };

      // The cell's part added to K and M: row by row where no DoF is constrained (serial matrices),
      // else through the constraints.
      template <typename MatrixType>
      void add_cell_contribution(const CellContribution &part, const AffineConstraints<double> &constraints,
                                 MatrixType &K, MatrixType &M)
      {
        if constexpr (std::is_same_v<MatrixType, SparseMatrix<double>>)
          if (!part.through_constraints)
            {
              add_sorted_cell_matrix(part.sorted_dofs, part.sorted_K, K);
              add_sorted_cell_matrix(part.sorted_dofs, part.sorted_M, M);
              return;
            }
        constraints.distribute_local_to_global(part.K, part.dof_indices, K);
        constraints.distribute_local_to_global(part.M, part.dof_indices, M);
      }
    } // namespace

    void ascending_dof_order(const std::vector<types::global_dof_index> &dofs, std::vector<unsigned int> &order)
    {
      order.resize(dofs.size());
      std::iota(order.begin(), order.end(), 0u);
      std::sort(order.begin(), order.end(), [&](const unsigned int i, const unsigned int j) { return dofs[i] < dofs[j]; });
    }

    void add_sorted_cell_matrix(const std::vector<types::global_dof_index> &sorted_dofs,
                                const FullMatrix<double> &cell_matrix, SparseMatrix<double> &matrix)
    {
      const unsigned int n = sorted_dofs.size();
      for (unsigned int i = 0; i < n; ++i)
        matrix.add(sorted_dofs[i], n, sorted_dofs.data(), &cell_matrix(i, 0), false, true);
    }

    template <typename MatrixType>
    MassMoments assemble_elasticity(const SceneParameters &scene, const Mapping<3> &mapping, const FiniteElement<3> &fe,
                                    const Quadrature<3> &quadrature,
                                    const std::vector<DoFHandler<3>::active_cell_iterator> &cells,
                                    const std::vector<ElasticFace> &elastic_faces,
                                    const AffineConstraints<double> &constraints, MatrixType &K, MatrixType &M)
    {
      using CellIterator = std::vector<DoFHandler<3>::active_cell_iterator>::const_iterator;
      MassMoments total;
      WorkStream::run(
        cells.cbegin(), cells.cend(),
        [&](const CellIterator &cell, AssemblyScratch &scratch, CellContribution &part) {
          scratch.fe_values.reinit(*cell);
          part.moments = MassMoments();
          scratch.assembler.assemble(scratch.fe_values, part.K, part.M, part.moments);
          (*cell)->get_dof_indices(part.dof_indices);
          part.through_constraints = !std::is_same_v<MatrixType, SparseMatrix<double>> ||
                                     std::any_of(part.dof_indices.begin(), part.dof_indices.end(),
                                                 [&](const auto dof) { return constraints.is_constrained(dof); });
          if (!part.through_constraints)
            part.sort_by_dof();
        },
        [&](const CellContribution &part) {
          add_cell_contribution(part, constraints, K, M);
          total += part.moments;
        },
        AssemblyScratch(mapping, fe, quadrature, scene.material), CellContribution(fe.n_dofs_per_cell()));
      FullMatrix<double>                   face_K(fe.n_dofs_per_cell(), fe.n_dofs_per_cell());
      std::vector<types::global_dof_index> dof_indices(fe.n_dofs_per_cell());
      for (const auto &face : elastic_faces)
        {
          elastic_face_matrix(mapping, fe, face, face_K);
          face.cell->get_dof_indices(dof_indices);
          constraints.distribute_local_to_global(face_K, dof_indices, K);
        }
      return total;
    }

    template MassMoments assemble_elasticity(const SceneParameters &, const Mapping<3> &, const FiniteElement<3> &,
                                             const Quadrature<3> &, const std::vector<DoFHandler<3>::active_cell_iterator> &,
                                             const std::vector<ElasticFace> &, const AffineConstraints<double> &,
                                             SparseMatrix<double> &, SparseMatrix<double> &);
    template MassMoments assemble_elasticity(const SceneParameters &, const Mapping<3> &, const FiniteElement<3> &,
                                             const Quadrature<3> &, const std::vector<DoFHandler<3>::active_cell_iterator> &,
                                             const std::vector<ElasticFace> &, const AffineConstraints<double> &,
                                             TrilinosWrappers::SparseMatrix &, TrilinosWrappers::SparseMatrix &);
  } // namespace assembly
} // namespace modal_haptics
