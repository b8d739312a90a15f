// Where linear stops being true: a geometrically nonlinear static solve on a modal space's own mesh,
// element degree and supports (total Lagrangian, hyperelastic), which ramps a contact's patch load
// up to 'Contact/Force limit' with Newton's method, and the validity forces read off its curve.
// Serial and distributed alike (SerialAlgebra, DistributedAlgebra): each process assembles its own
// cells, and the tangent systems go through the space's own direct solver (CHOLMOD or UMFPACK
// serially, MUMPS under MPI).
#pragma once

#include "parameters/scene_parameters.h"
#include "scene/display_surface.h"
#include "scene/supports.h"
#include "results/space_result.h"

#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace dealii
{
  namespace TrilinosWrappers
  {
    class SparseMatrix;
    namespace MPI
    {
      class Vector;
    }
  } // namespace TrilinosWrappers
} // namespace dealii

namespace modal_haptics
{
  class Factorization;      // solvers/factorization.h
  class DistributedInverse; // solvers/mumps_inverse.h

  namespace nonlinear
  {
    // The stored energies, both with the part's Lame constants and both equal to linear elasticity
    // at small strain: St. Venant-Kirchhoff W = lambda/2 (tr E)^2 + mu E:E (E = (F^T F - I)/2), and the
    // compressible neo-Hookean W = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2.
    enum class HyperelasticLaw
    {
      saint_venant_kirchhoff,
      neo_hookean
    };
    std::string law_name(HyperelasticLaw law);

    // How the load is ramped and when Newton has converged.
    struct LoadRamp
    {
      double       force_limit    = 10.; // [N]
      unsigned int load_steps     = 10;  // first increment = force_limit / load_steps
      unsigned int max_halvings   = 8;   // of the increment below force_limit / load_steps
      unsigned int max_iterations = 20;  // Newton iterations per load level
      double       tolerance      = 1e-8; // on |R| / |f|: residual over the load of the level (its rounding
                                          // floor on a slender steel beam: 2.5e-10)
      // Or on the felt displacement d = l^T u, the one number a level keeps: its error l^T T^-1 R,
      // estimated as u1^T R (u1 = K^-1 l, the adjoint at zero load; T's differs from it by the
      // curve's departure), relative to d. 0: the residual alone decides.
      double       felt_tolerance = 1e-7;
    };

    // The linear algebra of a space's backend as the nonlinear solve uses it: its vectors and
    // matrices, the pattern a tangent is built on, and the direct solver that factorizes one.
    struct SerialAlgebra
    {
      using Vector  = dealii::Vector<double>;
      using Matrix  = dealii::SparseMatrix<double>;
      using Pattern = dealii::SparsityPattern; // K's
      using Inverse = Factorization;           // CHOLMOD or UMFPACK, as 'Modes/Factorization' says
    };
    struct DistributedAlgebra
    {
      using Vector  = dealii::TrilinosWrappers::MPI::Vector;
      using Matrix  = dealii::TrilinosWrappers::SparseMatrix;
      using Pattern = dealii::TrilinosWrappers::SparseMatrix; // K itself: a tangent copies its pattern
      using Inverse = DistributedInverse; // MUMPS, as 'Modes/Distributed factorization' says
    };

    // What the solve reads of a space: its FE space (the triangulation's communicator: the
    // processes, one in a serial run), its supports (constraints, homogeneous, and this process's
    // elastic faces), the pattern of its K, the layouts of its vectors, and its factorization of K
    // (null: none, or not a direct one), which preconditions CG on the tangent systems when use_cg,
    // and K, the tangent at the unloaded state.
    template <typename Algebra>
    struct SpaceView
    {
      const dealii::DoFHandler<3>             &dof_handler;
      const dealii::Mapping<3>                &mapping;
      const dealii::Quadrature<3>             &quadrature;
      const dealii::AffineConstraints<double> &constraints;
      const typename Algebra::Pattern         &sparsity;
      const std::vector<ElasticFace>          &elastic_faces;
      typename Algebra::Vector                 owned_layout;   // zero, this process's rows
      typename Algebra::Vector                 ghosted_layout; // zero, readable at its cells' DoFs
      typename Algebra::Inverse               *linear_factorization = nullptr;
      bool                                     use_cg               = false;
      // K itself (with the supports), the tangent at u = 0 (null: assembled there like any other).
      const typename Algebra::Matrix          *stiffness            = nullptr;
    };

    // The Lame constants of the part's material: {mu, lambda} [Pa].
    std::array<double, 2> lame_constants(const MaterialParameters &material);

    // The modes the estimate projects on: the lowest ones, at most this many. The tensor grows as r^3
    // (r = 1000 would be 5e8 numbers and hours of GEMMs) while a mode's share of u1 falls as 1/lambda.
    constexpr unsigned int max_estimate_modes = 30;

    // The cubic term on the span of the lowest r = min(modes, max_estimate_modes) fields (the modes):
    // Psi3(sum_i q_i phi_i) = sum_ijk t_i,jk q_i q_j q_k with t symmetric in j, k (stored for j <= k),
    // assembled once over the quadrature points. Each process integrates over its own cells (the
    // modes readable there: ghosted in a distributed run) and sum_over_processes adds up the parts
    // (nothing to do in a serial run). VectorType: dealii::Vector<double> or
    // TrilinosWrappers::MPI::Vector.
    class ModalCubicTerm
    {
    public:
      template <typename VectorType>
      ModalCubicTerm(const dealii::DoFHandler<3> &dof_handler, const dealii::Mapping<3> &mapping,
                     const dealii::Quadrature<3> &quadrature, const MaterialParameters &material,
                     HyperelasticLaw law, const std::vector<VectorType> &modes,
                     const std::function<void(std::vector<double> &)> &sum_over_processes);
      unsigned int size() const { return r; }          // the modes it spans
      double value(const std::vector<double> &q) const; // [J], q of size()
      double seconds = 0.;                               // the assembly's wall time

    private:
      unsigned int        r;
      std::vector<double> t; // r x r(r+1)/2, row i, pairs (j <= k) in order
    };

    // The forces [N] where the linear compliance c1 departs by 1, 5, 10 % from the secant compliance
    // c1 + c2 F + c3 F^2 of a series curve: the least F > 0 where it reaches c1 / (1 - delta)
    // (softening) or c1 / (1 + delta) (stiffening). With c3 = 0, delta c1 / (|c2| (1 - delta)) where
    // c2 > 0 and delta c1 / (|c2| (1 + delta)) where c2 < 0; infinity where neither is reached.
    std::array<double, 3> series_validity_forces(double c1, double c2, double c3 = 0.);

    // The forces where the linear felt compliance departs by validity_departures from the secant
    // compliance of the curve (ValidityCurve::validity_force).
    void set_validity_forces(ValidityCurve &curve);

    // The direction a HIP presses along at a display vertex: the area-weighted normal of its
    // triangles, pointing into the part (the side where 'outside' [-], the distance of a point
    // outside the mesh, is smaller a small step away).
    std::array<double, 3> inward_normal(const ContactSurface &display, unsigned int vertex,
                                        const std::function<double(const meshing::Point3 &)> &outside);

    // The modal side of the estimate: the cubic term on the lowest modes, and load(v, d) = B_v^T d =
    // Phi^T W_v d on them (the cubic term's size() values).
    struct ModalView
    {
      const std::vector<dealii::Vector<double>> *serial_modes; // the modes themselves in a serial run
                                                               // (the full solves' check of the tensor), else null
      const ModalCubicTerm                      &cubic;
      std::function<std::vector<double>(unsigned int, const std::array<double, 3> &)> load;
    };
    // The modal estimate at a contact: c2 = -3 Psi3(Phi q), q_i = (B_v^T d)_i / lambda_i.
    double modal_second_order(const ModalView &modal, const ModalSpaceResult &result, unsigned int vertex,
                              const std::array<double, 3> &direction, std::vector<double> *q = nullptr);

    // The phase: the validity curve of each of task.validity_vertices into result.validity, on a
    // space held against every rigid motion (otherwise logged and left out). patch_load(v, d) gives
    // W_v d condensed. Collective in a distributed run (every process calls it alike, and so
    // patch_load and outside). Newton's residuals go to 'log' (progress), each contact's outcome to 'summarize'.
    // At each validity contact also both estimates (exact and modal) and their self-checks; the
    // validity map (when estimated) takes the full solve's forces at these contacts.
    template <typename Algebra>
    void analyse_validity(const SpaceView<Algebra> &space, const SceneParameters &scene, const SpaceTask &task,
                          const ContactSurface &display,
                          const std::function<typename Algebra::Vector(unsigned int, const std::array<double, 3> &)> &patch_load,
                          const std::function<double(const meshing::Point3 &)> &outside,
                          const std::function<std::optional<ModalView>()> &modal,
                          ModalSpaceResult &result, const std::function<void(std::string)> &log,
                          const std::function<void(std::string)> &summarize);

    // The phase before it: the validity map, at every display vertex where result.felt_stiffness > 0,
    // from the modal second-order estimate along the inward normal (minus the display surface's
    // outward normal, the felt-stiffness map's), c1 = 1 / felt_stiffness the exact corrected
    // compliance. A space with free rigid motions gets none (logged, validity_left_out).
    // make_modal is called only where the map is estimated (it assembles the cubic term).
    void estimate_validity_map(const ContactSurface &display, const std::function<ModalView()> &make_modal,
                               ModalSpaceResult &result, const std::function<void(std::string)> &summarize);
    // The law 'Contact/Validity material' names.
    HyperelasticLaw validity_law(const SceneParameters &scene);
  } // namespace nonlinear
} // namespace modal_haptics
