// What finite-element assembly of linear elasticity shares between a modal space (space/) and the
// large-deformation solve (nonlinear/): the cell matrices K and M with a cell's mass moments, the
// elastic supports' face matrices, and adding a cell's matrix to a serial matrix in ascending DoF
// order. Below both rooms: it knows a mesh, an element and a material, not a modal space.
#pragma once

#include "parameters/scene_parameters.h"
#include "scene/supports.h"

#include <deal.II/base/quadrature.h>
#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparse_matrix.h>

#include <vector>

namespace modal_haptics
{
  namespace assembly
  {
    // The rigid-body mass moments of some cells: their mass, first moment and second moment
    // (the integral of rho x x^T), added up cell by cell.
    struct MassMoments
    {
      double               mass = 0.;
      dealii::Tensor<1, 3> first;
      dealii::Tensor<2, 3> second;
      MassMoments &operator+=(const MassMoments &other);
    };

    // Cell matrices of isotropic linear elasticity (K) and consistent mass (M), and the cell's mass moments.
    class CellAssembler
    {
    public:
      CellAssembler(const MaterialParameters &material, unsigned int dofs_per_cell);
      void assemble(const dealii::FEValues<3> &fe_values, dealii::FullMatrix<double> &cell_K,
                    dealii::FullMatrix<double> &cell_M, MassMoments &moments);

    private:
      const MaterialParameters          material;
      const double                      mu, lambda;
      std::vector<unsigned int>         component;  // of each shape function (each has one nonzero)
      std::vector<dealii::Tensor<1, 3>> gradient;   // of that component, at one quadrature point
      std::vector<double>               value;
    };

    // The stiffness of an elastic support on one face: the integral over the face of
    // k_n (phi_i . n)(phi_j . n) + k_t (phi_i . phi_j - (phi_i . n)(phi_j . n)).
    void elastic_face_matrix(const dealii::Mapping<3> &mapping, const dealii::FiniteElement<3> &fe,
                             const ElasticFace &face, dealii::FullMatrix<double> &face_K);

    // The permutation that puts a cell's DoFs in ascending order: dofs[order[0]] < dofs[order[1]] < ...
    // (the order add_sorted_cell_matrix takes a cell's rows and columns in).
    void ascending_dof_order(const std::vector<dealii::types::global_dof_index> &dofs, std::vector<unsigned int> &order);

    // matrix += cell_matrix, whose rows and columns are the DoFs 'sorted_dofs' (ascending, none
    // constrained): row by row, the columns found in one pass over each row of the pattern.
    void add_sorted_cell_matrix(const std::vector<dealii::types::global_dof_index> &sorted_dofs,
                                const dealii::FullMatrix<double> &cell_matrix, dealii::SparseMatrix<double> &matrix);

    // K and M from the given DoF cells (on deal.II's threads; each cell added in the cells' order)
    // and K's share of the elastic supports on the given faces; returns the cells' mass moments.
    // MatrixType: dealii::SparseMatrix<double> or TrilinosWrappers::SparseMatrix (compressed by the caller).
    template <typename MatrixType>
    MassMoments assemble_elasticity(const SceneParameters &scene, const dealii::Mapping<3> &mapping,
                                    const dealii::FiniteElement<3> &fe, const dealii::Quadrature<3> &quadrature,
                                    const std::vector<dealii::DoFHandler<3>::active_cell_iterator> &cells,
                                    const std::vector<ElasticFace> &elastic_faces,
                                    const dealii::AffineConstraints<double> &constraints, MatrixType &K, MatrixType &M);
  } // namespace assembly
} // namespace modal_haptics
