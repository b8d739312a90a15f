// What one modal space computes, apart from how: the result types that the exporters, the partial
// results of scenario jobs, the study and the truncation read. No FE, mesh or backend headers: a
// reader of results compiles without them (the assembly and its helpers are in space/modal_space.h).
#pragma once

#include "solvers/solver_statistics.h"

#include <array>
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace modal_haptics
{
  struct DroppedMode
  {
    unsigned int index;     // 0-based index among the computed modes
    double       frequency; // [Hz]
    std::string  reason;
  };

  // Two candidates pressed together (z at the first, y at the second): neighbours, the nearest to a
  // pair of 'Exact pair points', or a pair farther apart; one full static FE solve against the
  // kernel's formula with the stored cross compliance (or the far field).
  struct TwoContactCheck
  {
    std::array<unsigned int, 2> vertices{}; // display vertices
    double distance = 0.;                   // between them [m]
    double rel_error_corrected = 0.;        // the worse of the two contacts' relative errors
    bool   far = false;                     // no stored cross block: the far field couples them
    bool   named = false;                   // the nearest candidates of a pair of 'Exact pair points'
    double rel_error_without_cross = 0.;    // the same with the pair's residual coupling left out
  };

  // The far-field coupling's error over one band of distances between two candidates: per pair,
  // |R_ab - Z_a Z_b^T|_F / sqrt(|C_aa|_F |C_bb|_F) with R_ab the exact residual compliance (from
  // full solves at sampled candidates), and what the modes alone leave out, |R_ab|_F / the same.
  struct FarFieldBand
  {
    double       from = 0., to = 0.; // [m]
    unsigned int pairs = 0;
    double       median_error = 0., p95_error = 0., max_error = 0., median_modes_alone = 0., p95_modes_alone = 0.;
  };

    // One full static FE solve of a unit patch load, compared with the modal and corrected answers.
  struct ValidationCase
  {
    unsigned int vertex    = 0; // display vertex
    unsigned int direction = 0; // 0, 1, 2 = x, y, z
    std::array<double, 3> full_response{};  // u_c = W^T K^-1 W e [m/N]
    double contact_rel_error_modal     = 0.; // |u_c,modal - u_c| / |u_c|
    double contact_rel_error_corrected = 0.; // |u_c,modal + C e - u_c| / |u_c|
    double field_rel_error_modal       = 0.; // l2 over the display surface, relative to the full field
    double field_max_error_modal       = 0.; // max over display vertices, relative to the full field's max
    double field_rel_error_corrected   = 0.; // the same with the correction field added, truncated
    std::vector<double> field_rel_error_by_modes; // [k-1]: field_rel_error_modal with the first k modes only
    unsigned int correction_field_vertices = 0; // display vertices the truncated correction field keeps
    double energy_rel_error_modal      = 0.; // sqrt((u - u_r)^T K (u - u_r) / u^T K u)
    double solve_relative_residual     = 0.; // ||K u - f|| / ||f|| of the full solve
  };

  // The felt force-displacement curve of one contact under a geometrically nonlinear full-FE solve
  // (precompute/nonlinear/large_deformation.h), and the forces up to which the linear felt
  // compliance holds (docs/report-schema.md, "validity").
  struct ValidityCurve
  {
    unsigned int          vertex = 0;   // display vertex
    std::array<double, 3> direction{};  // unit vector the patch load presses along
    std::string           material;     // the hyperelastic law of the solve
    double                linear_compliance = 0.; // d^T W^T K^-1 W d [m/N]
    std::vector<double>   forces;        // [N] converged load levels, ascending (0 left out)
    std::vector<double>   displacements; // [m] d^T W^T u at each: the felt displacement
    std::vector<unsigned int> newton_iterations;            // per converged level
    std::vector<std::vector<double>> newton_residuals;      // per converged level: |R| / |f| per iteration
    std::vector<double> newton_felt_errors; // per converged level: the felt displacement's estimated error
                                            // |u1^T R| / |d| at its last iterate (LoadRamp::felt_tolerance)
    double      force_limit   = 0.; // [N] 'Contact/Force limit'
    double      force_reached = 0.; // [N] the last converged level (= force_limit when complete)
    std::string stop_reason;        // empty when the limit was reached; else why the solve stopped
    // The force [N] where |c_linear / c_nonlinear - 1| first reaches 1 %, 5 %, 10 % (c = u / F, the
    // secant compliance felt), interpolated between levels; infinity when it is not reached up to the
    // force limit; force_reached when the solve stopped before (the part does not carry more).
    std::array<double, 3> validity_force{};
    double seconds = 0.; // wall time of the solve
    // The series estimates at this contact (docs/accuracy.md): the felt displacement
    // d(F) = c1 F + c2 F^2 + c3 F^3 + ..., c2 = -3 Psi3(u1), Psi3 the cubic term of the stored energy
    // and u1 the linear response to the unit load, once exact (u1 = K^-1 W_v d: one solve) and once
    // projected on the modes (u1 ~ Phi Lambda^-1 B_v^T d: what the validity map holds elsewhere);
    // and the exact third order, c3 = 2 u2^T K u2 - 4 Psi4(u1), u2 = -K^-1 grad Psi3(u1) (NaN where
    // an element inverts even at the smallest step of its finite differences).
    struct SeriesEstimate
    {
      double                c2 = 0.;          // [m/N^2]
      double                c3 = 0.;          // [m/N^3] (0 in the second-order estimates)
      std::array<double, 3> validity_force{}; // [N] where c1 / (c1 + c2 F + c3 F^2) departs by 1, 5, 10 %
    };
    SeriesEstimate estimate_exact, estimate_modal, estimate_third_order;
    double estimate_seconds = 0.; // the exact estimates: two solves, an integral and 6 assemblies
    // Self-check of the third order's finite differences (negative: not computed): their quadratic
    // term, c1 / 2 t^2, against the solve's c1; relative.
    double quadratic_term_check = -1.;
    // Self-checks of the cubic term (negative: not computed): Psi3(u1) by quadrature against the odd
    // part of the stored energy along t u1 (finite differences), and sum P_ijk q_i q_j q_k against
    // Psi3(Phi q) by quadrature; relative differences.
    double cubic_term_check = -1., modal_cubic_check = -1.;
  };
  constexpr std::array<double, 3> validity_departures = {{0.01, 0.05, 0.10}};
  // The validity map's value where a departure is not reached (docs/basis-format.md, VALIDITY_FORCE).
  constexpr double validity_not_reached = 1e30;

  // A space's result is read by three readers, one struct each: the basis (what the .mrt and .h5
  // files hold), its diagnostics (report.json) and the rows this process holds (MPI bookkeeping,
  // never written). for_each_field lists every written field once, with its name: the partial
  // result (partial_result.cc) serializes the basis and the diagnostics through it.

  // The modal basis of a space on the scene's display surface, its mesh and its validation.
  struct ModalBasis
  {
    std::string  name;
    unsigned int index = 0; // 0 = global
    unsigned int degree = 2;
    unsigned int n_vertices = 0, n_cells = 0, n_dofs = 0;

    std::vector<double>       mesh_vertices; // 3 per vertex [m]
    std::vector<unsigned int> mesh_tets;     // 4 per tet
    std::vector<unsigned int> clamped_dofs;

    std::vector<double> eigenvalues;    // the kept modes [rad^2/s^2]
    std::vector<double> frequencies_hz;
    std::vector<double> damping_ratios;

    std::vector<double> modes_at_vertices; // r x n_vertices x 3 [1/sqrt(kg)] (r x owned vertices x 3, see ProcessRows)
    std::vector<double> display_modes;     // (3 nv) x r row-major: (3v + c) r + i

    std::vector<unsigned int> candidates;
    std::vector<double>       candidate_modes;      // nc x 3 x r
    std::vector<double>       candidate_compliance; // nc x 3 x 3 [m/N]
    // The residual compliance between neighbouring candidates (closer than 'Contact/Cross compliance
    // radius'): candidate a's neighbours are cross_neighbours[cross_offsets[a] .. cross_offsets[a + 1])
    // (candidate indices, ascending, a itself left out), block (a, b) = W_a^T (K^-1 - Phi Lambda^-1
    // Phi^T) W_b 3 x 3 row-major at the same position of cross_blocks (9 each) [m/N]. Empty offsets:
    // not stored.
    std::vector<unsigned int> cross_offsets, cross_neighbours;
    std::vector<double>       cross_blocks;
    // The residual coupling of candidates without a stored block: R_ab ~ Z_a Z_b^T, Z_a the 3 x k
    // rows (3a + i) k + j of far_compliance [sqrt(m/N)], k = far_rank (0: none), a Nystrom factor of
    // the residual compliance between all candidates (space/phase_far_field.h).
    std::vector<double> far_compliance;
    unsigned int        far_rank = 0;
    // The felt-stiffness map: the normal stiffness 1 / (n^T W_v^T K^-1 W_v n) [N/m] of the patch load
    // along the outward normal n, at the space's candidates and shared vertices (0 elsewhere: the
    // scene's map takes each vertex from the space whose region holds it), and what the modes alone
    // would give there, 1 / (n^T B_v Lambda^-1 B_v^T n).
    std::vector<double> felt_stiffness, modal_only_stiffness;
    // The validity map: F1, F5, F10 [N] per display vertex (3 v + 0, 1, 2) where felt_stiffness > 0:
    // the full nonlinear solve's at the validity contacts, the modal second-order estimate elsewhere;
    // 0 = no value, validity_not_reached = not reached. Empty when not computed.
    std::vector<double> validity_force;

    std::vector<double>         participation; // r x 6
    double                      mass = 0.;     // [kg]
    std::array<double, 3>       centre_of_mass{};
    std::array<double, 9>       inertia{};     // about the centre of mass [kg m^2]
    std::vector<ValidationCase> validation;
    std::vector<ValidityCurve>  validity; // the nonlinear solves at the space's validity contacts

    template <typename Self, typename Visitor>
    static void for_each_field(Self &b, Visitor &&field)
    {
      field("name", b.name), field("index", b.index), field("degree", b.degree);
      field("n_vertices", b.n_vertices), field("n_cells", b.n_cells), field("n_dofs", b.n_dofs);
      field("mesh_vertices", b.mesh_vertices), field("mesh_tets", b.mesh_tets), field("clamped_dofs", b.clamped_dofs);
      field("eigenvalues", b.eigenvalues), field("frequencies_hz", b.frequencies_hz);
      field("damping_ratios", b.damping_ratios), field("modes_at_vertices", b.modes_at_vertices);
      field("display_modes", b.display_modes), field("candidates", b.candidates);
      field("candidate_modes", b.candidate_modes), field("candidate_compliance", b.candidate_compliance);
      field("cross_offsets", b.cross_offsets), field("cross_neighbours", b.cross_neighbours);
      field("cross_blocks", b.cross_blocks), field("far_compliance", b.far_compliance), field("far_rank", b.far_rank);
      field("felt_stiffness", b.felt_stiffness);
      field("modal_only_stiffness", b.modal_only_stiffness), field("validity_force", b.validity_force);
      field("participation", b.participation);
      field("mass", b.mass), field("centre_of_mass", b.centre_of_mass), field("inertia", b.inertia);
      field("validation", b.validation), field("validity", b.validity);
    }
  };

  // How a space was computed and how well: what report.json says beyond the basis.
  struct SpaceDiagnostics
  {
    unsigned int             n_clamped_dofs = 0;
    std::vector<double>      computed_frequencies_hz; // every computed mode
    std::vector<DroppedMode> dropped_modes;
    double                   cut_off_hz = 0.;
    EigenSelfCheck           self_check;
    unsigned int             n_spurious_rows = 0; // constrained rows, moved to lambda = infinity
    std::map<unsigned int, std::array<double, 9>> full_compliance; // W^T K^-1 W at shared vertices
    double two_contact_rel_error_corrected = -1.; // the worst two-contact check (< 0: none)
    // The far-field factor's cost and its error by distance (against sampled exact columns).
    double                    far_field_seconds = 0.;
    std::vector<unsigned int> far_field_sampled; // the candidates (display vertices) whose columns were solved
    std::vector<FarFieldBand> far_field_bands;
    double                    far_field_rms_error = 0., far_field_rms_modes_alone = 0.; // over the sampled pairs
    std::string               far_field_left_out; // why a computed factor was not kept (empty: kept)
    std::vector<TwoContactCheck> two_contact_checks;

    // What the supports caught, and the rigid-body motions they leave free (a free-floating part:
    // all six): the lowest modes, stored as the exact motions at 0 Hz.
    std::string         supports_summary;
    std::string         free_motions; // "translation along x, rotation about z"; empty: none
    unsigned int        n_rigid_body_modes = 0;
    std::vector<double> rigid_computed_frequencies_hz; // what the eigensolver found, signed sqrt(lambda) / 2 pi
    double              rigid_subspace_sine = 0.;      // >= sin of the largest angle, computed vs exact rigid span
    unsigned int        static_solve_iterations = 1;   // most refinement steps one static solve took

    FactorizationStatistics factorization;
    std::string             eigensolver_method;
    unsigned int            n_operator_applications = 0;
    // The eigensolver's iteration with its solves, after the factorization (ARPACK, PARPACK or the
    // block Krylov solver; report.json's "arpack_s").
    double                  eigensolve_iteration_seconds = 0.;
    double                  mass_product_seconds = 0.;      // block Krylov: products with M, in the iteration
    double                  orthogonalization_seconds = 0.; // block Krylov: Gram-Schmidt, in the iteration
    double                  correction_seconds_per_candidate = 0.;
    std::map<std::string, double> timings_s;     // assembly, eigensolve, static_correction, validation
    // The validity map's estimate: the modal cubic tensor's assembly, the contacts it covers and the
    // time per contact after it; why it was left out (empty: it was not).
    double       validity_tensor_seconds = 0., validity_seconds_per_contact = 0.;
    unsigned int validity_estimated_contacts = 0;
    std::string  validity_left_out;

    template <typename Self, typename Visitor>
    static void for_each_field(Self &d, Visitor &&field)
    {
      field("n_clamped_dofs", d.n_clamped_dofs), field("computed_frequencies_hz", d.computed_frequencies_hz);
      field("dropped_modes", d.dropped_modes), field("cut_off_hz", d.cut_off_hz), field("self_check", d.self_check);
      field("n_spurious_rows", d.n_spurious_rows), field("full_compliance", d.full_compliance);
      field("two_contact_rel_error_corrected", d.two_contact_rel_error_corrected);
      field("two_contact_checks", d.two_contact_checks);
      field("far_field_seconds", d.far_field_seconds), field("far_field_sampled", d.far_field_sampled);
      field("far_field_bands", d.far_field_bands), field("far_field_rms_error", d.far_field_rms_error);
      field("far_field_rms_modes_alone", d.far_field_rms_modes_alone), field("far_field_left_out", d.far_field_left_out);
      field("supports_summary", d.supports_summary), field("free_motions", d.free_motions);
      field("n_rigid_body_modes", d.n_rigid_body_modes);
      field("rigid_computed_frequencies_hz", d.rigid_computed_frequencies_hz);
      field("rigid_subspace_sine", d.rigid_subspace_sine), field("static_solve_iterations", d.static_solve_iterations);
      field("factorization", d.factorization), field("eigensolver_method", d.eigensolver_method);
      field("n_operator_applications", d.n_operator_applications);
      field("eigensolve_iteration_seconds", d.eigensolve_iteration_seconds);
      field("mass_product_seconds", d.mass_product_seconds);
      field("orthogonalization_seconds", d.orthogonalization_seconds);
      field("correction_seconds_per_candidate", d.correction_seconds_per_candidate), field("timings_s", d.timings_s);
      field("validity_tensor_seconds", d.validity_tensor_seconds);
      field("validity_seconds_per_contact", d.validity_seconds_per_contact);
      field("validity_estimated_contacts", d.validity_estimated_contacts);
      field("validity_left_out", d.validity_left_out);
    }
  };

  // The rows of the whole mesh a process of a distributed run holds (docs/cluster.md): mesh_vertices
  // and modes_at_vertices then hold the vertices listed here, in this order, and mesh_tets the tets
  // listed here; the parallel HDF5 writer puts every row in its place in the file.
  struct ProcessRows
  {
    std::vector<unsigned int> vertices, tets; // indices in the whole mesh
  };

  struct ModalSpaceResult : ModalBasis, SpaceDiagnostics
  {
    std::optional<ProcessRows> owned_rows; // empty: every row, in mesh order (the serial run)
    std::size_t n_vertex_rows() const { return owned_rows ? owned_rows->vertices.size() : n_vertices; }
  };

  // The static gain 1 / lambda of a mode, and 0 for a rigid-body mode (lambda = 0): the static
  // answers of a free-floating part are those of inertia relief (the load's resultant accelerates the
  // part, the rest deforms it), to which rigid-body modes contribute no deflection.
  inline double static_gain(const double lambda) { return lambda > 0. ? 1. / lambda : 0.; }

  // What a space must compute beyond its modes: chosen scene-wide, before any space is solved.
  struct SpaceTask
  {
    std::string                 name;
    unsigned int                index = 0;
    std::string                 msh_file;
    std::map<std::string, int>  physical_surfaces;
    std::vector<unsigned int>   candidates;         // display vertices with a static correction
    std::vector<unsigned int>   validation_vertices; // a subset of candidates
    std::vector<unsigned int>   shared_vertices;    // vertices whose full compliance every space reports
    std::vector<unsigned int>   validity_vertices;  // 'Validation points' in this space's region: nonlinear solves
  };

  // The space with its first r modes only (r <= its count), as if the eigensolve had kept r: the
  // static correction grows by the dropped modes' share, C_v(r) = C_v + sum_{i >= r} b_i b_i^T / lambda_i
  // (and so for the cross-compliance), so corrected contacts stay exact. Validation cases keep the
  // errors of the full count (their full-FE responses stay true).
  ModalSpaceResult truncate_modal_space(const ModalSpaceResult &space, unsigned int r);

} // namespace modal_haptics
