// The vertex (P1) space of a higher-order space and the interpolation from it, for the two-level
// preconditioner (amg_eigensolver.h: make_vertex_space_transfer), and whether DoFs are node-blocked.
#include "solvers/amg_eigensolver.h"
#include "scene/rigid_body_motion.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>

#include <algorithm>
#include <vector>

namespace modal_haptics
{
  using dealii::ExcMessage;

  namespace
  {
    // weights(i, j): vertex shape function j at the support point of the space's shape function i
    // when both belong to the same displacement component (else 0): the interpolation of a linear
    // field into the space, cell by cell.
    dealii::FullMatrix<double> cell_interpolation(const dealii::FiniteElement<3> &fe,
                                                  const dealii::FiniteElement<3> &vertex_fe)
    {
      dealii::FullMatrix<double> weights(fe.n_dofs_per_cell(), vertex_fe.n_dofs_per_cell());
      for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
        for (unsigned int j = 0; j < vertex_fe.n_dofs_per_cell(); ++j)
          if (fe.system_to_component_index(i).first == vertex_fe.system_to_component_index(j).first)
            {
              const double w = vertex_fe.shape_value(j, fe.get_unit_support_points()[i]);
              weights(i, j)  = std::abs(w) < 1e-12 ? 0. : w;
            }
      return weights;
    }
  } // namespace

  bool node_blocked(const dealii::DoFHandler<3> &dof_handler, const MPI_Comm comm)
  {
    const auto                                  &fe = dof_handler.get_fe();
    std::vector<dealii::types::global_dof_index> dofs(fe.n_dofs_per_cell());
    bool                                         blocked = true;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(dofs);
          for (unsigned int i = 0; i < dofs.size(); ++i)
            blocked = blocked && dofs[i] % 3 == fe.system_to_component_index(i).first;
        }
    return dealii::Utilities::MPI::min(int(blocked), comm) == 1;
  }

  VertexSpaceTransfer make_vertex_space_transfer(const dealii::DoFHandler<3>             &dof_handler,
                                                 const dealii::Mapping<3>                &mapping,
                                                 const dealii::AffineConstraints<double> &constraints,
                                                 const MPI_Comm                           comm)
  {
    using namespace dealii;
    const FESystem<3> vertex_fe(FE_SimplexP<3>(1), 3);
    DoFHandler<3>     vertex_dofs(dof_handler.get_triangulation());
    vertex_dofs.distribute_dofs(vertex_fe);
    const FiniteElement<3>   &fe           = dof_handler.get_fe();
    const IndexSet           &owned        = dof_handler.locally_owned_dofs();
    const IndexSet           &vertex_owned = vertex_dofs.locally_owned_dofs();
    const FullMatrix<double>  weights      = cell_interpolation(fe, vertex_fe);
    const std::size_t         n_vertex     = vertex_owned.n_elements();

    VertexSpaceTransfer transfer;
    transfer.near_null_space.assign(6 * n_vertex, 0.);
    std::vector<bool> held(n_vertex, false); // the space's DoF at this vertex DoF is constrained
    DynamicSparsityPattern pattern(dof_handler.n_dofs(), vertex_dofs.n_dofs(), owned);
    std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell()), vertex_dof_indices(vertex_fe.n_dofs_per_cell());
    // visit(cell) on each locally owned cell, with dofs and vertex_dof_indices filled for it: both
    // handlers walk the same cells in the same order.
    const auto for_each_owned_cell = [&](const auto &visit) {
      auto vertex_cell = vertex_dofs.begin_active();
      for (const auto &cell : dof_handler.active_cell_iterators())
        {
          const auto this_vertex_cell = vertex_cell++;
          if (!cell->is_locally_owned())
            continue;
          cell->get_dof_indices(dofs);
          this_vertex_cell->get_dof_indices(vertex_dof_indices);
          visit(cell);
        }
    };
    // couple(i, j) for each owned DoF i of the cell and each vertex DoF j its interpolation weighs.
    const auto for_each_coupling = [&](const auto &couple) {
      for (unsigned int i = 0; i < dofs.size(); ++i)
        if (owned.is_element(dofs[i]))
          for (unsigned int j = 0; j < vertex_dof_indices.size(); ++j)
            if (weights(i, j) != 0.)
              couple(i, j);
    };
    for_each_owned_cell([&](const auto &cell) {
      for (unsigned int j = 0; j < vertex_dof_indices.size(); ++j)
        {
          const types::global_dof_index g = vertex_dof_indices[j];
          const unsigned int c = vertex_fe.system_to_component_index(j).first;
          if (!vertex_owned.is_element(g))
            continue;
          const std::size_t k = vertex_owned.index_within_set(g);
          const Point<3>    x = mapping.transform_unit_to_real_cell(cell, vertex_fe.get_unit_support_points()[j]);
          for (unsigned int m = 0; m < 6; ++m)
            transfer.near_null_space[m * n_vertex + k] = rigid_body_motion(m, x)[c];
        }
      for_each_coupling([&](const unsigned int i, const unsigned int j) {
        pattern.add(dofs[i], vertex_dof_indices[j]);
        if (weights(i, j) == 1. && constraints.is_constrained(dofs[i]) && vertex_owned.is_element(vertex_dof_indices[j]))
          held[vertex_owned.index_within_set(vertex_dof_indices[j])] = true;
      });
    });
    for (std::size_t k = 0; k < n_vertex; ++k)
      if (held[k])
        for (unsigned int m = 0; m < 6; ++m)
          transfer.near_null_space[m * n_vertex + k] = 0.;
    transfer.node_blocked = node_blocked(vertex_dofs, comm);

    transfer.prolongation = std::make_shared<TrilinosWrappers::SparseMatrix>();
    TrilinosWrappers::SparseMatrix &P = *transfer.prolongation;
    P.reinit(owned, vertex_owned, pattern, comm);
    for_each_owned_cell([&](const auto &) {
      for_each_coupling([&](const unsigned int i, const unsigned int j) { P.set(dofs[i], vertex_dof_indices[j], weights(i, j)); });
    });
    P.compress(VectorOperation::insert);
    return transfer;
  }
} // namespace modal_haptics
