// modal-study's records and its parts that need no deal.II. What a study point is and what it
// measures (the rows of study.csv, the references of reference.csv); the real-time kernel's cost
// on a basis file (study_kernel_cost.cc, by running bench-basis-cost: the precompute never includes
// the kernel); the study's outputs (study_output.cc: the two tables, then study.md and the plots by
// scripts/study_report.py); how the study finds and runs those companions (child_process.cc). The
// sweep itself, which needs the precompute, is modal_study.cc.
#pragma once

#include "results/space_result.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace modal_haptics
{
  // One run of the pipeline: which mesh, which discretization, which contact and eigensolver.
  struct PointSettings
  {
    std::string  mesh; // "graded", "uniform" or "reference"
    unsigned int degree = 2;
    double       coarse_size = 0., fine_size = 0., patch_radius = 0.; // [geometry units]
    std::string  eigensolver = "block-krylov";
    unsigned int modes = 0;

    std::string label() const
    {
      std::ostringstream name;
      name << mesh << "_p" << degree << "_c" << coarse_size << "_f" << fine_size << "_rho" << patch_radius << "_"
           << eigensolver;
      return name.str();
    }
  };

  using Compliance = std::array<double, 9>; // 3 x 3 row-major [m/N]

  inline double along(const Compliance &G, const std::array<double, 3> &n)
  {
    double value = 0.;
    for (unsigned int i = 0; i < 3; ++i)
      for (unsigned int j = 0; j < 3; ++j)
        value += n[i] * G[3 * i + j] * n[j];
    return value;
  }

  inline double frobenius_distance(const Compliance &A, const Compliance &B)
  {
    double d = 0.;
    for (unsigned int k = 0; k < 9; ++k)
      d += (A[k] - B[k]) * (A[k] - B[k]);
    return std::sqrt(d);
  }

  inline double frobenius_norm(const Compliance &A) { return frobenius_distance(A, Compliance{}); }

  // A sampled contact in one point's run: its display vertex, push direction and compliances.
  struct Contact
  {
    unsigned int          vertex = 0, candidate = 0;
    std::array<double, 3> direction{}; // the study's push direction
    Compliance            full{};     // W^T K^-1 W of this point's mesh
    Compliance            corrected{}; // B Lambda^-1 B^T + C_v: what the kernel renders at the candidate
  };

  // What the real-time kernel costs on one basis file: admittance ticks of one HIP pressing with
  // 1 N along the push direction on `vertex`, and a whole display reconstruction.
  struct KernelCost
  {
    double tick_p50_ns = 0., tick_p99_ns = 0., corrected_tick_p50_ns = 0., corrected_tick_p99_ns = 0.;
    double display_ms = 0.;
    unsigned int display_vertices = 0;
  };

  // The secant compliance delta(F) / F [m/N] a nonlinear curve gives at `force`, interpolated linearly
  // in F between its levels (it equals the linear compliance at F = 0); NaN beyond force_reached (the
  // part did not carry it). The force axis of a study.
  inline double secant_compliance(const ValidityCurve &curve, const double force)
  {
    if (curve.forces.empty() || force > curve.force_reached * (1. + 1e-12))
      return std::nan("");
    double previous_force = 0., previous_secant = curve.linear_compliance;
    for (std::size_t k = 0; k < curve.forces.size(); ++k)
      {
        const double secant = curve.displacements[k] / curve.forces[k];
        if (force <= curve.forces[k])
          return previous_secant + (secant - previous_secant) * (force - previous_force) / (curve.forces[k] - previous_force);
        previous_force = curve.forces[k], previous_secant = secant;
      }
    return previous_secant;
  }

  struct ReferenceSolution
  {
    double                  patch_radius = 0.;
    unsigned int            n_dofs = 0;
    double                  seconds = 0.;
    std::vector<Contact>    contacts;
    std::vector<ValidityCurve> curves; // the nonlinear solve per contact, when the study has 'Force levels'
    std::vector<double>     frequencies_hz;
  };

  // One row of study.csv.
  struct StudyRow
  {
    PointSettings point;
    std::string   r_rule; // "count" or the cut-off rule that chose r
    unsigned int  r = 0, n_dofs = 0, candidates = 0;
    double felt_error_modal = 0., felt_error_corrected = 0.;         // felt compliance d^T G d vs reference (max over contacts)
    double felt_error_modal_3x3 = 0., felt_error_corrected_3x3 = 0.; // Frobenius, relative
    double truncation_error = 0.;    // felt compliance, modal vs this mesh's full FE (max over contacts)
    double correction_residual = 0.; // |B Lambda^-1 B^T + C_v - W^T K^-1 W| / |W^T K^-1 W|
    double display_error_modal = 0.; // l2 display field, modal vs this mesh's full FE (max over cases)
    double frequency_error_first = 0., frequency_error_max = 0.;
    unsigned int frequencies_compared = 0;
    std::map<std::string, double> seconds; // meshing, assembly, eigensolve, static_correction, validation, total
    double correction_ms_per_candidate = 0.;
    std::uintmax_t mrt_bytes = 0;
    KernelCost kernel;
    std::vector<double> corrected_felt_compliance; // per contact [m/N]
    // Per force level of the study: |c / c_nonlinear(F) - 1| of the corrected and the modal-only felt
    // compliance against the reference's nonlinear secant compliance (max over contacts; NaN where the
    // reference did not carry F).
    std::vector<double> felt_error_corrected_at_force, felt_error_modal_at_force;
  };

  // study_kernel_cost.cc: the kernel loading `basis_file` and pressing on `contact` for `ticks`
  // admittance ticks, without and with the static correction: bench-basis-cost, run as a child.
  KernelCost measure_kernel(const std::string &basis_file, const Contact &contact, unsigned int ticks);

  // study_output.cc: <output_directory>/reference.csv and study.csv, each written atomically.
  // With force levels, also force_curves.csv: the reference's nonlinear curve at each contact.
  void write_reference_table(const std::string &output_directory, const std::vector<ReferenceSolution> &references);
  void write_study_table(const std::string &output_directory, const std::vector<StudyRow> &rows,
                         const std::vector<double> &force_levels);

  // study_output.cc: scripts/study_report.py on the tables (study.md and the plots); its exit status.
  int write_report(const std::string &output_directory);

  // child_process.cc: the file `name` in the first folder that holds it: each of `from_bin` relative
  // to this program's folder, then `build_folder`; else an exception naming them (and `hint`).
  std::filesystem::path find_companion(const std::string &name, const std::vector<std::string> &from_bin,
                                       const std::string &build_folder, const std::string &hint);

  // child_process.cc: runs arguments[0] (a path) with the rest as its arguments and waits for it; its
  // standard output goes to `output` if not null, else to ours. Returns its exit status; throws
  // (naming `hint`) if it cannot be started.
  int run_child(std::vector<std::string> arguments, std::string *output, const std::string &hint);
} // namespace modal_haptics
