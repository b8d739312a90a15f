// One modal space: a scenario's mesh, its stiffness and mass, its lowest modes, and everything
// the kernel needs of it on the scene's display surface (modes, contact blocks, static correction,
// participation factors), checked against full static FE.
#pragma once

#include "display_surface.h"
#include "eigensolver.h"
#include "scene_parameters.h"

#include <deal.II/base/timer.h>

#include <array>
#include <map>
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

  struct ModalSpaceResult
  {
    std::string  name;
    unsigned int index = 0; // 0 = global
    unsigned int degree = 2;
    unsigned int n_vertices = 0, n_cells = 0, n_dofs = 0, n_clamped_dofs = 0;

    std::vector<double>       mesh_vertices; // 3 per vertex [m]
    std::vector<unsigned int> mesh_tets;     // 4 per tet
    std::vector<unsigned int> clamped_dofs;

    std::vector<double>      computed_frequencies_hz; // every computed mode
    std::vector<double>      eigenvalues;             // the kept modes [rad^2/s^2]
    std::vector<double>      frequencies_hz;
    std::vector<double>      damping_ratios;
    std::vector<DroppedMode> dropped_modes;
    double                   cut_off_hz = 0.;
    EigenSelfCheck           self_check;
    unsigned int             n_spurious_rows = 0; // constrained rows, moved to lambda = infinity

    std::vector<double> modes_at_vertices; // r x n_vertices x 3 [1/sqrt(kg)]
    std::vector<double> display_modes;     // (3 nv) x r row-major: (3v + c) r + i

    std::vector<unsigned int> candidates;
    std::vector<double>       candidate_modes;      // nc x 3 x r
    std::vector<double>       candidate_compliance; // nc x 3 x 3 [m/N]
    std::vector<double>       cross_compliance;     // (3nc) x (3nc), empty when not stored
    std::map<unsigned int, std::array<double, 9>> full_compliance; // W^T K^-1 W at shared vertices

    std::vector<double>         participation; // r x 6
    double                      mass = 0.;     // [kg]
    std::array<double, 3>       centre_of_mass{};
    std::array<double, 9>       inertia{};     // about the centre of mass [kg m^2]
    std::vector<ValidationCase> validation;
    double two_contact_rel_error_corrected = -1.; // two simultaneous contacts (< 0: not checked)

    FactorizationStatistics factorization;
    std::string             eigensolver_method;
    unsigned int            n_operator_applications = 0;
    double                  arpack_seconds = 0.; // the Lanczos iteration with its solves, after the factorization
    double                  correction_seconds_per_candidate = 0.;
    std::map<std::string, double> timings_s;     // assembly, eigensolve, static_correction, validation
  };

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
    std::string                 vtu_file;           // mode shapes + validation error fields, or empty
  };

  // The space with its first r modes only (r <= its count), as if the eigensolve had kept r: the
  // static correction grows by the dropped modes' share, C_v(r) = C_v + sum_{i >= r} b_i b_i^T / lambda_i
  // (and so for the cross-compliance), so corrected contacts stay exact. Validation cases keep the
  // errors of the full count (their full-FE responses stay true).
  ModalSpaceResult truncate_modal_space(const ModalSpaceResult &space, unsigned int r);

  // Runs the whole pipeline of one space: read mesh, assemble, eigensolve, select, interpolate on
  // the display surface, static correction, validation, VTU output.
  ModalSpaceResult compute_modal_space(const SceneParameters &scene,
                                       const DisplaySurface  &display,
                                       const SpaceTask       &task,
                                       dealii::TimerOutput   &timer,
                                       bool                   verbose);
} // namespace modal_haptics
