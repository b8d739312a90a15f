// The steps a space takes whatever the linear algebra, shared by the serial space (modal_space.cc)
// and the distributed one (distributed_space.cc): the order of the phases (SpaceBase::run), mesh,
// supports, mode selection, point location and patch loads (space_parts.cc), what the static
// correction and the validation record (space_records.cc). FE headers; space_result.h has none.
#pragma once

#include "assembly/elasticity.h"
#include "parameters/scene_parameters.h"
#include "results/space_result.h"
#include "scene/display_surface.h"
#include "scene/rigid_body_motion.h"
#include "scene/supports.h"
#include "solvers/eigensolver.h"
#include "solvers/solver_choice.h"
#include "space/contact_blocks.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/grid_tools_cache.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparse_matrix.h>

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <variant>

#include <array>
#include <map>
#include <string>
#include <vector>

namespace modal_haptics
{
  // The steps a space takes whatever the linear algebra: used by the serial space (CHOLMOD,
  // modal_space.cc) and the distributed one (Trilinos + MUMPS, distributed_space.cc), so that both
  // compute the same quantities the same way.
  namespace space_parts
  {
    using DofWeights = std::vector<std::pair<dealii::types::global_dof_index, double>>;

    // W_v: the consistent nodal load of a unit patch traction, one sparse DoF list per direction.
    using PatchLoad = std::array<DofWeights, 3>;

    // The scene's 'Modes' settings that the solver choice reads (solver_choice.h).
    solver_choice::Settings solver_settings(const SceneParameters &scene);

    // Reads the space's mesh (geometry units -> m), refuses inverted or degenerate tets and fills
    // the result's mesh fields.
    void read_mesh(const SceneParameters &scene, const SpaceTask &task, dealii::Triangulation<3> &mesh,
                   ModalSpaceResult &result);

    // The scene's supports on a space's FE space (supports.h): their constraints added to
    // 'constraints' (closed by the caller), what each caught logged, and the motions they leave free
    // checked against the eigensolve's settings: a free motion needs a negative shift and a maximum
    // number of modes above the number of free motions.
    // The summary lines of a space (what each support caught, the motions left free, why the modes
    // kept were kept) are printed by process 0 with or without progress lines once a program turns
    // them on (modal-precompute, also with --quiet); off, they are progress lines (modal-study).
    void print_space_summaries(bool on);

    // Supports that leave rigid-body motions free need a negative 'Modes/Shift' and more modes than
    // free motions; else refused naming the motions, as "Space 'NAME': the supports ..." (an empty
    // 'space': "The supports ...", --validate's prediction from the geometry).
    void check_free_motions(const SceneParameters &scene, const FreeMotions &free, const std::string &space);

    ResolvedSupports apply_supports(const SceneParameters &scene, const SpaceTask &task, const dealii::Mapping<3> &mapping,
                                    const dealii::DoFHandler<3> &dof_handler, dealii::AffineConstraints<double> &constraints,
                                    const std::function<void(std::string)> &log, MPI_Comm comm = MPI_COMM_SELF);

    // Mass, centre of mass and inertia of the cells whose moments these are into 'result', each
    // moment summed over 'reduce' (identity when serial).
    void set_mass_properties(const assembly::MassMoments &moments, ModalSpaceResult &result,
                             const std::function<double(double)> &reduce = [](double x) { return x; });

    // Everything a phase (space/phase_*.h) reads besides its backend and the result.
    struct PhaseInputs
    {
      const SceneParameters                 &scene;
      const ContactSurface                  &display;
      const SpaceTask                       &task;
      const std::string                     &vtu_file;
      const bool                             verbose;
      const std::function<void(std::string)> log;
    };

    // What a space is made of whatever the linear algebra: its inputs, its FE space, its result and
    // the order of its phases, each timed twice (the program's TimerOutput table, and per space for
    // the report).
    class SpaceBase
    {
    public:
      SpaceBase(const SceneParameters &scene, const ContactSurface &display, const SpaceTask &task,
                const std::string &vtu_file, dealii::TimerOutput &timer, bool verbose);
      virtual ~SpaceBase() = default;
      // The space's result, or the choice that hands it to another backend after the eigensolve
      // phase chose (a serial run's space to MUMPS on this process: compute_modal_space).
      std::variant<ModalSpaceResult, solver_choice::Choice> run();

    protected:
      virtual void assemble() = 0; // mesh, DoFs, clamps, K and M
      virtual void after_assembly() {}
      virtual void solve_eigenproblem() = 0; // as 'choice' says, and mode selection
      virtual void interpolate() = 0;        // display surface, mesh vertices, participation factors
      virtual void compute_static_correction() = 0;
      virtual void compute_far_field() = 0;
      virtual void validate() = 0;
      // The validity map's estimate at every corrected contact, and the nonlinear solves at the
      // validity contacts (precompute/nonlinear/), serial and distributed.
      virtual void estimate_validity() = 0;
      virtual void analyse_validity()  = 0;
      virtual void output_results() const = 0;
      virtual void finish() {}
      void log(const std::string &message) const;       // a progress line: not printed with --quiet
      void summarize(const std::string &message) const; // a summary line (print_space_summaries)
      PhaseInputs inputs() const
      {
        return {scene, display, task, vtu_file, verbose, [this](const std::string &message) { log(message); }};
      }

      const SceneParameters        &scene;
      const ContactSurface         &display;
      const SpaceTask              &task;
      const std::string             vtu_file; // mode shapes + validation error fields, or empty
      dealii::TimerOutput          &timer;
      const bool                    verbose;
      const dealii::FESystem<3>     fe;
      const dealii::MappingFE<3>    mapping;
      const dealii::QGaussSimplex<3> quadrature;
      ModalSpaceResult              result;
      ResolvedSupports              supports; // set with the constraints (apply_supports)
      solver_choice::Choice         choice; // backend, method, factor placement (solve_eigenproblem)
    };

    // Applies the cut-off rule to the ascending computed eigenvalues: fills the result's computed and
    // kept frequencies, kept eigenvalues, damping and dropped modes; returns the kept modes' indices.
    std::vector<unsigned int> select_modes(const SceneParameters &scene, const std::vector<double> &eigenvalues,
                                           ModalSpaceResult &result);
    // The eigenvalue shift sigma [1/s^2] of 'Modes/Shift' f [Hz]: sign(f) (2 pi f)^2, what both
    // backends factorize K - sigma M with.
    double shift_eigenvalue(const ModeParameters &modes);
    // When the eigensolve has found what select_modes needs (every eigensolver stops there).
    CutOffStop cut_off_stop(const ModeParameters &modes);
    // What an eigensolver that states its count up front seeks, for its log line: "50 modes", or
    // "up to 50 modes, until the cut-off's count is decided".
    std::string sought_modes(const ModeParameters &modes);
    // Why select_modes kept what it kept, in the parameters' names: "kept 10 modes: 4 below the 500 Hz
    // cut-off ('Modes/Cut-off rule' = haptic: half 'Modes/Haptic rate'), raised to the floor of 10
    // ('Modes/Minimum number of modes'); dropped 1 above it" (no "dropped" when none was).
    std::string mode_selection_summary(const SceneParameters &scene, const ModalSpaceResult &result);

    // A point of the display surface located in the cells of a mesh that this process owns (all of a
    // serial mesh): the tet with the largest smallest barycentric coordinate among those whose
    // bounding boxes hold the point or are the nearest, so that a point slightly outside a coarse
    // mesh's chordal facets is projected onto the closest cell. Without an owned cell: an invalid
    // cell, infinitely far outside.
    struct LocatedPoint
    {
      dealii::Triangulation<3>::active_cell_iterator cell;
      dealii::Point<3>                               unit;             // in the reference tet
      double                                         distance_outside; // 0 inside, else the clipped barycentric
    };
    class PointLocator
    {
    public:
      static constexpr unsigned int n_nearest = 12; // bounding boxes tried

      PointLocator(const dealii::Triangulation<3> &mesh, const dealii::Mapping<3> &mapping);
      // Among the cells whose boxes hold x and, unless one of them holds x, those of its n_nearest
      // nearest boxes, these within 'within' (a
      // squared distance [m^2]): a distributed mesh locates a point on every process among the boxes
      // nearest over all processes, so that it tries the serial locator's cells.
      LocatedPoint locate(const meshing::Point3 &x,
                          double within = std::numeric_limits<double>::infinity()) const;
      // The squared distances [m^2] to the n_nearest nearest boxes, ascending (infinity for missing ones).
      std::array<double, n_nearest> nearest_box_distances(const meshing::Point3 &x) const;

    private:
      std::vector<std::pair<dealii::BoundingBox<3>, dealii::Triangulation<3>::active_cell_iterator>>
      nearest_boxes(const meshing::Point3 &x) const;

      dealii::GridTools::Cache<3> cache;
    };

    // Where a point is evaluated: its DoF cell and its coordinates in the reference tet; an invalid
    // cell when another process evaluates it.
    struct EvaluationPoint
    {
      dealii::DoFHandler<3>::active_cell_iterator cell;
      dealii::Point<3>                            unit;
    };

    // The FE basis at a point: the values N_j there of the scalar element's n functions (the same
    // for the three displacement components) and, per component c, the DoF of each function,
    // dofs[c n + j]; empty at a point another process evaluates. 'cell' (the active cell's index)
    // groups the points of a patch that share their DoFs.
    struct ShapeRow
    {
      std::vector<double>                          values;
      std::vector<dealii::types::global_dof_index> dofs;
      unsigned int                                 cell = dealii::numbers::invalid_unsigned_int;

      // Component c's DoFs with their nonzero values.
      DofWeights component(unsigned int c) const;
    };
    ShapeRow shape_row(const EvaluationPoint &point);

    // W_v from its patch quadrature (patch_quadrature) and the shape rows of its points, in the same
    // order; points another process evaluates add nothing here.
    PatchLoad make_patch_load(const std::vector<SurfacePoint> &quadrature, const std::vector<const ShapeRow *> &rows);

    // B_v Lambda^-1 B_v^T e_direction at a candidate.
    std::array<double, 3> modal_patch_response(const ModalSpaceResult &result, unsigned int candidate,
                                               unsigned int direction);

    // What the iteration of a factorization's eigensolver (block Krylov, ARPACK) reports: its solves
    // and their time, with its M products and orthogonalization apart.
    void record_iteration(ModalSpaceResult &result, const EigenSolution &solution);

    // The loads of a space's static correction and what is recorded of each: the candidates (by
    // default every display vertex of the space's region) and the shared vertices; the groups they
    // are solved in and each candidate's neighbours (contact_blocks.h).
    struct StaticCorrectionPlan
    {
      std::vector<unsigned int> loads;          // display vertices, ascending
      std::vector<int>          load_of_vertex; // per display vertex: its index in loads, or -1
      ContactBlockPlan          blocks;         // groups of loads; neighbours of the candidates
      std::vector<double>       normals;        // the display surface's outward normals, 3 per vertex
      std::vector<double>       load_modes;     // B_v = W_v^T Phi per load, 3 x r row-major each
    };

    // Sizes the result's candidate blocks, cross-compliance rows and maps; the plan's load_modes
    // are the caller's to fill (they need the modes).
    StaticCorrectionPlan plan_static_correction(const SceneParameters &scene, const SpaceTask &task,
                                                const ContactSurface &display, ModalSpaceResult &result);

    // Records what the solves K^-1 W_v e_d of load number 'load' (vertex v) give: its full
    // compliance (the felt-stiffness map; the shared vertices' full_compliance), and at a candidate
    // its residual compliance and its cross compliance with each neighbour.
    // averaged(vertex, d) = W_vertex^T K^-1 W_v e_d for v itself and its neighbours; nullopt at a
    // neighbour whose block comes from the neighbour's own solve (complete_cross_blocks).
    void record_static_response(
      ModalSpaceResult &result, const SpaceTask &task, const StaticCorrectionPlan &plan, unsigned int load,
      const std::function<std::optional<std::array<double, 3>>(unsigned int, unsigned int)> &averaged);
    // Fills each cross block that no solve recorded with the transpose of its pair's block (K is
    // symmetric); throws if neither was recorded.
    void complete_cross_blocks(ModalSpaceResult &result);
    // The display vertices whose responses a load's solve must give: the load itself, then (at a
    // candidate) its neighbours.
    std::vector<unsigned int> response_vertices(const ModalSpaceResult &result, const StaticCorrectionPlan &plan,
                                                unsigned int load);
    std::string static_correction_summary(const ModalSpaceResult &result, std::size_t n_loads);
    // "far field: rank k, ... s; coupling error (median, against the modes alone) by distance".
    std::string far_field_summary(const ModalSpaceResult &result);

    // A static solve with the factorization of A = K - shift M is refined against K itself: 'refine'
    // makes one step u += A^-1 (f - K u) on its right-hand sides (the first from u = 0) and returns
    // the worst relative residual ||f - K u|| / ||f|| after it. Each step shrinks an elastic mode's
    // error by |shift| / |lambda - shift|. Steps until the residual is <= 1e-12, or until it stops
    // shrinking (the rounding floor) at <= 1e-6; anything else throws, naming the space and
    // 'Modes/Shift' (shift_hz). Returns the number of steps. Both backends' solve_static use it.
    unsigned int refine_static_solve(const std::function<double()> &refine, const std::string &space_name,
                                     double shift_hz);

    // The validation errors of one case from the patch averages (uc) and the fields at the display
    // vertices (3 nv each, component-fastest) of the full and the modal solution, the latter the sum
    // of modal_coefficients[i] times mode i.
    void set_validation_errors(ValidationCase &vc, const ModalSpaceResult &result, const ContactSurface &display,
                               double correction_field_tolerance, const std::array<double, 3> &uc_full,
                               const std::array<double, 3> &uc_modal, const std::vector<double> &display_full,
                               const std::vector<double> &display_modal, const std::vector<double> &modal_coefficients);

    // The two-hand checks: pairs of neighbouring candidates pushed at once with 'forces'; the
    // kernel's formula with the cross compliance against the full answers at both (patch averages).
    constexpr std::array<std::array<double, 3>, 2> two_contact_forces = {{{{0., 0., 1.}}, {{0., 1., 0.}}}};
    // 'count' pairs (a, b) of candidates, b a neighbour of a, drawn with a fixed seed.
    std::vector<std::array<unsigned int, 2>> two_contact_pairs(const ModalSpaceResult &result, unsigned int count);
    // The scene's 'Exact pair points' in metres.
    std::vector<std::array<std::array<double, 3>, 2>> exact_pair_points(const SceneParameters &scene);
    // Per pair of 'Exact pair points', the candidates nearest to its two points (display vertices),
    // where both lie within 'Exact pair reach' and differ: the pairs the exact links were made for.
    std::vector<std::array<unsigned int, 2>> named_contact_pairs(const ModalSpaceResult &result, const SceneParameters &scene,
                                                                 const ContactSurface &display);
    // 'count' pairs of candidates without a stored cross block (the far field couples them), drawn
    // with a fixed seed; none when the space has no far field.
    std::vector<std::array<unsigned int, 2>> far_contact_pairs(const ModalSpaceResult &result, unsigned int count);
    // The worse of the two contacts' relative errors; with_cross_residual = false leaves the pair's
    // residual coupling out (what the modes alone give between them).
    double two_contact_error(const ModalSpaceResult &result, const std::array<unsigned int, 2> &vertices,
                             const std::array<std::array<double, 3>, 2> &full_responses, bool with_cross_residual = true);
    // The residual compliance C_ab of two candidates (indices), as the kernel couples them: their own
    // C at a == b, the stored cross block of neighbours, else the far field's Z_a Z_b^T, else zero
    // (9 values, row-major).
    std::array<double, 9> residual_compliance(const ModalSpaceResult &result, unsigned int a, unsigned int b);

    // One summary line of the validation for the log.
    std::string validation_summary(const ModalSpaceResult &result);

    // VTU field names: mode i (0-based) with its frequency, and a validation case's error field.
    std::string mode_field_name(unsigned int i, double frequency_hz);
    std::string validation_field_name(const ValidationCase &vc);
  } // namespace space_parts
} // namespace modal_haptics
