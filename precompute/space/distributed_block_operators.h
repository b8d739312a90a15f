// The distributed backend's operators of the block Krylov eigensolver (solvers/eigensolver.h's
// BlockEigenOperators), included by distributed_space.cc.
#pragma once

#include "solvers/eigensolver.h"
#include "solvers/mumps_inverse.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/mpi.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <Epetra_CrsMatrix.h>
#include <Epetra_MultiVector.h>

#include <string>

namespace modal_haptics
{
  // The block Krylov eigensolver's operators (eigensolver.h) on this process's rows: Epetra's
  // product with M (it imports the ghost entries), MUMPS's solves a block at a time (its factor
  // read once per block, where PARPACK's reverse communication hands out one vector per solve),
  // the inner products summed by MPI.
  class DistributedBlockOperators : public BlockEigenOperators
  {
  public:
    DistributedBlockOperators(const dealii::TrilinosWrappers::SparseMatrix &M, const DistributedInverse &inverse,
                              const dealii::TrilinosWrappers::MPI::Vector &layout, const MPI_Comm comm)
      : M(M.trilinos_matrix())
      , inverse(inverse)
      , layout(layout)
      , comm(comm)
    {
      AssertThrow(local_rows() > 0, dealii::ExcMessage("The block eigensolver needs unknowns on every process; process " +
                                               std::to_string(process()) + " has none (fewer processes?)."));
    }
    std::size_t  local_rows() const override { return layout.locally_owned_size(); }
    std::size_t  global_rows() const override { return layout.size(); }
    unsigned int process() const override { return dealii::Utilities::MPI::this_mpi_process(comm); }

    void multiply_by_mass(const double *src, double *dst, const int count) override
    {
      // Views on the column-major blocks: nothing is copied.
      const int                rows = int(local_rows());
      const Epetra_MultiVector X(View, M.OperatorDomainMap(), const_cast<double *>(src), rows, count);
      Epetra_MultiVector       Y(View, M.OperatorRangeMap(), dst, rows, count);
      AssertThrow(M.Multiply(false, X, Y) == 0, dealii::ExcMessage("Epetra's product with M failed."));
    }

    void solve(double *columns, const int count) override { inverse.solve_block(columns, count); }

    void sum_over_processes(double *values, const std::size_t count) const override
    {
      const int ierr = MPI_Allreduce(MPI_IN_PLACE, values, int(count), MPI_DOUBLE, MPI_SUM, comm);
      AssertThrowMPI(ierr);
    }

  private:
    const Epetra_CrsMatrix   &M;
    const DistributedInverse &inverse;
    const dealii::TrilinosWrappers::MPI::Vector &layout;
    const MPI_Comm            comm;
  };
} // namespace modal_haptics
