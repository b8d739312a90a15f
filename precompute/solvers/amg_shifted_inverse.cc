// AmgShiftedInverse (amg_eigensolver.h), the path without a factor: its set-up (ML's smoothed
// aggregation with the rigid-body near-null space, or the two levels over the vertex space), and
// Belos' block CG with the same preconditioner for the static solves, deflated by the modes.
// Its LOBPCG runs: amg_lobpcg.cc.
#include "solvers/amg_parts.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/timer.h>

#include <algorithm>
#include <string>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using namespace amg;

  void AmgShiftedInverse::Impl::set_up(const double shift_, const std::vector<unsigned int> &constrained_,
                                       const bool node_blocked, const VertexSpaceTransfer *vertex_space)
  {
    AssertThrow(shift_ <= 0., ExcMessage("The LOBPCG + AMG eigensolver needs 'Modes/Shift' <= 0 (K - shift M must "
                                         "be positive definite for the AMG and CG); it is " +
                                         std::to_string(std::sqrt(shift_) / (2. * M_PI)) + " Hz."));
    shift       = shift_;
    constrained = constrained_;
    A_product   = std::make_unique<ThreadedMatrix>(A->trilinos_matrix());
    M_product   = std::make_unique<ThreadedMatrix>(M->trilinos_matrix());
    Epetra_Vector diagonal(A->trilinos_matrix().RowMap());
    A->trilinos_matrix().ExtractDiagonalCopy(diagonal);
    for (const unsigned int k : constrained)
      constrained_diagonal.push_back(diagonal[k]);

    const std::size_t n_local = A->local_size();
    for (unsigned int j = 0; j < 6; ++j)
      for (const unsigned int k : constrained)
        near_null_space[j * n_local + k] = 0.;
    if (vertex_space == nullptr)
      {
        amg.initialize(*A, ml_parameters(near_null_space, node_blocked, A->m()));
        return;
      }
    vertex_near_null_space = vertex_space->near_null_space;
    prolongation           = vertex_space->prolongation;
    vertex_two_level       = std::make_unique<VertexTwoLevel>(
      A->trilinos_matrix(), *A_product, prolongation->trilinos_matrix(),
      ml_parameters(vertex_near_null_space, vertex_space->node_blocked, prolongation->n()));
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::SparseMatrix<double>           &K,
                                       const dealii::SparseMatrix<double>           &M,
                                       const double                                  shift,
                                       const std::array<dealii::Vector<double>, 6> &rigid_body_motions,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const VertexSpaceTransfer                    *vertex_space)
    : impl(std::make_unique<Impl>())
  {
    dealii::Timer timer;
    // Drop tolerance 0: deal.II's default drops entries below 1e-13 in absolute value, which a
    // mass matrix in SI units of a small part can hold.
    impl->own_A.reinit(K, 0.);
    impl->own_M.reinit(M, 0.);
    if (shift != 0.)
      impl->own_A.add(-shift, impl->own_M);
    impl->A = &impl->own_A, impl->M = &impl->own_M;
    const std::size_t n = K.m();
    impl->near_null_space.resize(6 * n);
    for (unsigned int j = 0; j < 6; ++j)
      std::copy(rigid_body_motions[j].begin(), rigid_body_motions[j].end(), impl->near_null_space.begin() + j * n);
    impl->set_up(shift, constrained, node_blocked, vertex_space);
    describe(node_blocked, timer.wall_time());
  }

  AmgShiftedInverse::AmgShiftedInverse(const dealii::TrilinosWrappers::SparseMatrix &K,
                                       const dealii::TrilinosWrappers::SparseMatrix &M,
                                       const double                                  shift,
                                       std::vector<double>                           near_null_space,
                                       const std::vector<unsigned int>              &constrained,
                                       const bool                                    node_blocked,
                                       const VertexSpaceTransfer                    *vertex_space)
    : impl(std::make_unique<Impl>())
  {
    dealii::Timer timer;
    impl->A = &K, impl->M = &M;
    if (shift != 0.)
      {
        impl->own_A.copy_from(K);
        impl->own_A.add(-shift, M);
        impl->A = &impl->own_A;
      }
    impl->near_null_space = std::move(near_null_space);
    impl->set_up(shift, constrained, node_blocked, vertex_space);
    describe(node_blocked, timer.wall_time());
  }

  void AmgShiftedInverse::describe(const bool node_blocked, const double setup_seconds)
  {
    stats.method = std::string("amg-block-cg (Trilinos ML smoothed aggregation, rigid-body near-null space") +
                   (node_blocked ? ", 3 DoFs per node" : ", DoF-wise aggregation") +
                   (impl->vertex_two_level ? ", on the vertex (P1) space under " + impl->vertex_two_level->smoother_interval() + ")" :
                                             std::string(")"));
    stats.analyze_seconds = setup_seconds;
  }

  AmgShiftedInverse::~AmgShiftedInverse() = default;

  const AmgSolverStatistics &AmgShiftedInverse::amg_statistics() const { return impl->stats; }

  std::string AmgShiftedInverse::preconditioner_name() const
  {
    return "AMG (ML, rigid-body near-null space" +
           (impl->vertex_two_level ? "; on the vertex space, " + impl->vertex_two_level->smoother_interval() : "") + ")";
  }

  std::string AmgShiftedInverse::eigensolver_method() const
  {
    const unsigned int runs = impl->stats.n_lobpcg_runs;
    return "LOBPCG (Trilinos Anasazi" +
           (runs > 1 ? ", " + std::to_string(runs) + " runs of at most " + std::to_string(impl->stats.modes_per_run) +
                         " modes" :
                       std::string()) +
           ") + AMG (Trilinos ML), no factorization";
  }

  void AmgShiftedInverse::deflate_by_modes(const std::vector<dealii::Vector<double>> &modes)
  {
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector Z(map, int(modes.size()), false);
    for (std::size_t c = 0; c < modes.size(); ++c)
      std::copy(modes[c].begin(), modes[c].end(), Z[c]);
    impl->deflate(std::move(Z));
  }

  void AmgShiftedInverse::deflate_by_modes(const std::vector<dealii::TrilinosWrappers::MPI::Vector> &modes)
  {
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector Z(map, int(modes.size()), false);
    for (std::size_t c = 0; c < modes.size(); ++c)
      {
        const Epetra_MultiVector &mode = modes[c].trilinos_vector();
        AssertThrow(mode.MyLength() == Z.MyLength(), ExcMessage("A mode's rows differ from the matrix's."));
        std::copy(mode[0], mode[0] + mode.MyLength(), Z[c]);
      }
    impl->deflate(std::move(Z));
  }

  // The columns are solved together by block CG.
  void AmgShiftedInverse::solve_block(double *columns, const unsigned int n_rhs)
  {
    if (n_rhs == 0)
      return;
    dealii::Timer            timer;
    const std::size_t        n   = impl->A->m();
    const Epetra_Map        &map = impl->A->trilinos_matrix().OperatorDomainMap();
    const Epetra_MultiVector B(Copy, map, columns, int(n), int(n_rhs));
    Epetra_MultiVector       X(View, map, columns, int(n), int(n_rhs));
    impl->block_conjugate_gradients(X, B);
    stats.solve_seconds += timer.wall_time();
    stats.n_solved_vectors += n_rhs;
  }

  // The columns (this process's rows of each) copied into one block and solved together.
  void AmgShiftedInverse::solve_columns(std::vector<dealii::TrilinosWrappers::MPI::Vector> &columns)
  {
    if (columns.empty())
      return;
    dealii::Timer      timer;
    const Epetra_Map  &map = impl->A->trilinos_matrix().OperatorDomainMap();
    Epetra_MultiVector B(map, int(columns.size())), X(map, int(columns.size()));
    for (std::size_t c = 0; c < columns.size(); ++c)
      {
        const Epetra_MultiVector &column = columns[c].trilinos_vector();
        AssertThrow(column.MyLength() == B.MyLength(), ExcMessage("A right-hand side's rows differ from the matrix's."));
        std::copy(column[0], column[0] + column.MyLength(), B[c]);
      }
    impl->block_conjugate_gradients(X, B);
    for (std::size_t c = 0; c < columns.size(); ++c)
      std::copy(X[c], X[c] + X.MyLength(), columns[c].trilinos_vector()[0]);
    stats.solve_seconds += timer.wall_time();
    stats.n_solved_vectors += columns.size();
  }
} // namespace modal_haptics
