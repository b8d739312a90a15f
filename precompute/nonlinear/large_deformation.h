// Where linear stops being true: a geometrically nonlinear static solve on a modal space's own mesh,
// element degree and supports (total Lagrangian, hyperelastic), which ramps a contact's patch load
// up to 'Contact/Force limit' with Newton's method, and the validity forces read off its curve.
// Serial: it factorizes each tangent with the space's own factorization (CHOLMOD or UMFPACK).
#pragma once

#include "parameters/scene_parameters.h"
#include "scene/display_surface.h"
#include "scene/supports.h"
#include "space/space_result.h"

#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace modal_haptics
{
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
    };

    // What the solve reads of a space: its FE space, its supports (constraints, homogeneous, and the
    // elastic faces' springs) and the sparsity pattern of its K.
    struct SpaceView
    {
      const dealii::DoFHandler<3>             &dof_handler;
      const dealii::Mapping<3>                &mapping;
      const dealii::Quadrature<3>             &quadrature;
      const dealii::AffineConstraints<double> &constraints;
      const dealii::SparsityPattern           &sparsity;
      const std::vector<ElasticFace>          &elastic_faces;
      FactorizationKind                        factorization;
    };

    class LargeDeformationSolve
    {
    public:
      LargeDeformationSolve(const SpaceView &space, const MaterialParameters &material, HyperelasticLaw law);

      // The dead load F * load ramped from 0 to ramp.force_limit: 'load' is a condensed unit patch
      // load W_v d (zero on constrained DoFs), which also reads the felt displacement d^T W_v^T u.
      // Each level starts from the last converged one; a level Newton cannot reach (an inverted
      // element at every step length of the line search, a tangent that is not positive definite,
      // no convergence) is retried with half the increment, up to ramp.max_halvings; then the curve
      // stops with stop_reason and force_reached. Newton's relative residuals go to 'log', one line
      // per level.
      ValidityCurve ramp_load(const dealii::Vector<double> &load, const LoadRamp &ramp,
                              const std::function<void(std::string)> &log);

    private:
      // rhs = force * load - f_int(u) on the free DoFs, the potential energy (stored minus the load's
      // work); the tangent too when with_tangent. False when some quadrature point has det F <= 0
      // (nothing is assembled then).
      bool assemble(const dealii::Vector<double> &u, double force, const dealii::Vector<double> &load,
                    bool with_tangent);
      struct LevelOutcome
      {
        bool                converged = false;
        std::vector<double> residuals; // |R| / |f| per iteration
        std::string         failure;
      };
      // Newton from the predictor (from u, the last converged state, where it inverts an element) to
      // the level 'force'; u is updated only when converged.
      LevelOutcome solve_level(dealii::Vector<double> &u, double force, const dealii::Vector<double> &load,
                               const dealii::Vector<double> &predictor, const LoadRamp &ramp,
                               const std::function<void(std::string)> &log);
      // tangent^-1 rhs into du; false (and 'failure') when the tangent is not positive definite.
      bool solve_tangent(dealii::Vector<double> &du, std::string &failure);

      const SpaceView       space;
      const double          mu, lambda;
      const HyperelasticLaw law;
      dealii::SparseMatrix<double> tangent;
      dealii::Vector<double>       rhs;
      double                       energy = 0.; // [J]
    };

    // The forces where the linear felt compliance departs by validity_departures from the secant
    // compliance of the curve (ValidityCurve::validity_force).
    void set_validity_forces(ValidityCurve &curve);

    // The direction a HIP presses along at a display vertex: the area-weighted normal of its
    // triangles, pointing into the part (the side where 'outside' [-], the distance of a point
    // outside the mesh, is smaller a small step away).
    std::array<double, 3> inward_normal(const ContactSurface &display, unsigned int vertex,
                                        const std::function<double(const meshing::Point3 &)> &outside);

    // The phase: the validity curve of each of task.validity_vertices into result.validity, on a
    // space held against every rigid motion (otherwise logged and left out). patch_load(v, d) gives
    // W_v d condensed. Newton's residuals go to 'log' (progress), each contact's outcome to 'summarize'.
    void analyse_validity(const SpaceView &space, const SceneParameters &scene, const SpaceTask &task,
                          const ContactSurface &display,
                          const std::function<dealii::Vector<double>(unsigned int, const std::array<double, 3> &)> &patch_load,
                          const std::function<double(const meshing::Point3 &)> &outside, ModalSpaceResult &result,
                          const std::function<void(std::string)> &log,
                          const std::function<void(std::string)> &summarize);
  } // namespace nonlinear
} // namespace modal_haptics
