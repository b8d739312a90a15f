// modal-study: the speed/accuracy trade of one scene, measured.
//
//   modal-study STUDY.prm [--output-dir DIR] [--no-report] [--verbose]
//
// A study point is one run of the whole precompute (meshing, assembly, eigensolve, static correction,
// validation, export) on the scene with some of its settings changed: element degree, coarse size,
// the studied VOI's fine size (a graded mesh) or one size everywhere (a uniform mesh), contact patch
// radius, eigensolver. The mode count r, the cut-off rule and the static correction on/off are read off
// each point's eigensolve without solving again (truncation keeps the lowest modes and moves the
// dropped ones into the correction, so a corrected contact stays exact). Accuracy is measured against
// a reference the study builds itself: the same part on a uniform mesh of 'Reference size' with
// P2 elements, its full static FE compliance at the study's contact points and its lowest frequencies.
// Cost comes from the points' own timers, the .mrt written for each r, and the real-time kernel
// loading that file and ticking on it: bench-basis-cost (benchmarks/realtime), run as a child process,
// since the precompute never includes the kernel.
//
// Output: study.csv (a row per point and r), reference.csv, points/<point>/ (each run's results), and
// study.md with the plots, written by scripts/study_report.py (unless --no-report).
//
// This file is the study's sweep (its parameters, the points, the pipeline run at each, the
// errors against the reference); modal_study.h holds the records it fills, study_kernel_cost.cc
// has the kernel timed by bench-basis-cost, study_output.cc writes the tables and has the report
// written, child_process.cc finds and runs those two companions.
#include "output/atomic_file.h"
#include "solvers/factorization.h"
#include "pipeline/modal_precompute.h"
#include "study/modal_study.h"
#include "parameters/scene_parameters.h"

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

namespace modal_haptics
{
  namespace fs = std::filesystem;
  using dealii::ExcMessage;
  namespace Patterns = dealii::Patterns;

  struct StudyParameters
  {
    std::string                study_file, scene_file, scenario, contact_points;
    std::array<double, 3>      push_direction{{0., 0., -1.}}; // unit
    std::vector<unsigned int>  degrees, mode_counts;
    std::vector<double>        coarse_sizes, fine_sizes, uniform_sizes, patch_radii; // [geometry units]
    std::vector<double>        force_levels; // [N] ascending; empty: no force axis
    std::vector<std::string>   cut_off_rules, eigensolvers;
    double                     reference_size = 1.; // [geometry units]
    unsigned int               reference_modes = 10;
    unsigned int               kernel_ticks = 20000;
  };

  void declare_study_parameters(dealii::ParameterHandler &prm)
  {
    prm.enter_subsection("Study");
    prm.declare_entry("Scene file", "ribbed_panel.prm", Patterns::FileName(),
                      "The scene studied (.prm), relative to the study file's folder. Units: none.");
    prm.declare_entry("Scenario", "", Patterns::Anything(),
                      "Name of the scene's VOI scenario whose contacts are studied; the scene's other VOIs "
                      "are left out of every point. Units: none.");
    prm.declare_entry("Contact points", "", Patterns::Anything(),
                      "Sampled contacts 'x, y, z; x, y, z; ...' on the part's surface inside the studied VOI: "
                      "the nearest display vertex of each point's surface is loaded. Units: geometry units.");
    prm.declare_entry("Push direction", "0, 0, -1", Patterns::List(Patterns::Double(), 3, 3),
                      "The direction the hand pushes in at every contact: the felt compliance is d^T G d, whose "
                      "sign does not matter; the force axis ('Force levels') pushes along d, so there d must "
                      "point into the part. A fixed direction, not the surface normal, because a contact on a "
                      "rib's narrow top may snap to an edge vertex whose normal leans sideways. Units: none.");
    prm.declare_entry("Element degrees", "2", Patterns::List(Patterns::Integer(1, 2), 1),
                      "Polynomial degrees of the tets (1, 2). Units: none.");
    prm.declare_entry("Coarse sizes", "6", Patterns::List(Patterns::Double(1e-9), 1),
                      "Element sizes outside the VOI of graded meshes. Units: geometry units.");
    prm.declare_entry("Fine sizes", "1.5", Patterns::List(Patterns::Double(1e-9), 1),
                      "The VOI's element size of graded meshes (each with each coarse size above it). Units: geometry units.");
    prm.declare_entry("Uniform sizes", "", Patterns::List(Patterns::Double(1e-9)),
                      "Element sizes of uniform meshes (no VOI), to compare graded and uniform meshing at "
                      "equal contact accuracy. Units: geometry units.");
    prm.declare_entry("Mode counts", "5, 10, 20, 50", Patterns::List(Patterns::Integer(1), 1),
                      "Numbers of modes r read off each point's eigensolve (the largest is computed). Units: none.");
    prm.declare_entry("Cut-off rules", "", Patterns::List(Patterns::Selection("display|haptic")),
                      "Also the r that each cut-off rule keeps (modes below half the display or haptic rate "
                      "of the scene, among the computed ones). Units: none.");
    prm.declare_entry("Patch radii", "2", Patterns::List(Patterns::Double(0.), 1),
                      "Contact patch radii rho (each gets its own reference). Units: geometry units.");
    prm.declare_entry("Eigensolvers", "block-krylov", Patterns::List(Patterns::Selection("block-krylov|arpack|arpack-umfpack|lobpcg-amg"), 1),
                      "Eigensolvers: block Krylov or ARPACK over CHOLMOD, ARPACK over UMFPACK, or LOBPCG + AMG "
                      "(no factorization). Units: none.");
    prm.declare_entry("Reference size", "1", Patterns::Double(1e-9),
                      "Element size of the uniform P2 reference mesh. Units: geometry units.");
    prm.declare_entry("Reference modes", "10", Patterns::Integer(1),
                      "Lowest frequencies of the reference compared with each point's. Units: none.");
    prm.declare_entry("Force levels", "", Patterns::List(Patterns::Double(0.)),
                      "Contact forces at which every point's felt compliance (corrected and modal-only) is "
                      "compared with the geometrically nonlinear one of the reference: the reference then also "
                      "solves, at each contact, the large-deformation problem (the scene's 'Contact/Validity "
                      "material') of a dead patch load along 'Push direction' up to the largest level, one "
                      "Newton solve per contact on the reference mesh. Empty: no force axis. Units: N.");
    prm.declare_entry("Kernel ticks", "20000", Patterns::Integer(100),
                      "Admittance ticks timed per point and r (one HIP pressing on the first contact point). Units: none.");
    prm.leave_subsection();
  }

  template <typename T>
  std::vector<T> parse_list(const std::string &text)
  {
    std::vector<T> values;
    for (const auto &item : dealii::Utilities::split_string_list(text))
      {
        std::istringstream in(item);
        T                  value;
        in >> value;
        values.push_back(value);
      }
    return values;
  }

  std::string number(const double value)
  {
    std::ostringstream out;
    out << std::setprecision(17) << value;
    return out.str();
  }

  StudyParameters read_study_parameters(const std::string &study_file)
  {
    dealii::ParameterHandler prm;
    declare_study_parameters(prm);
    AssertThrow(fs::is_regular_file(study_file), ExcMessage("Cannot read the study file '" + study_file + "'."));
    prm.parse_input(study_file);
    StudyParameters study;
    study.study_file = study_file;
    prm.enter_subsection("Study");
    study.scene_file      = (fs::path(study_file).parent_path() / prm.get("Scene file")).lexically_normal().string();
    study.scenario        = prm.get("Scenario");
    study.contact_points  = prm.get("Contact points");
    const auto direction  = parse_list<double>(prm.get("Push direction"));
    const double length   = std::sqrt(direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2]);
    AssertThrow(length > 0., ExcMessage(study_file + ": 'Study/Push direction' must not be zero."));
    for (unsigned int c = 0; c < 3; ++c)
      study.push_direction[c] = direction[c] / length;
    study.degrees         = parse_list<unsigned int>(prm.get("Element degrees"));
    study.coarse_sizes    = parse_list<double>(prm.get("Coarse sizes"));
    study.fine_sizes      = parse_list<double>(prm.get("Fine sizes"));
    study.uniform_sizes   = parse_list<double>(prm.get("Uniform sizes"));
    study.mode_counts     = parse_list<unsigned int>(prm.get("Mode counts"));
    study.cut_off_rules   = dealii::Utilities::split_string_list(prm.get("Cut-off rules"));
    study.patch_radii     = parse_list<double>(prm.get("Patch radii"));
    study.eigensolvers    = dealii::Utilities::split_string_list(prm.get("Eigensolvers"));
    study.reference_size  = prm.get_double("Reference size");
    study.reference_modes = prm.get_integer("Reference modes");
    study.kernel_ticks    = prm.get_integer("Kernel ticks");
    study.force_levels    = parse_list<double>(prm.get("Force levels"));
    prm.leave_subsection();
    AssertThrow(fs::is_regular_file(study.scene_file),
                ExcMessage(study_file + ": 'Study/Scene file' names '" + study.scene_file + "', which cannot be read."));
    AssertThrow(!study.scenario.empty(),
                ExcMessage(study_file + ": 'Study/Scenario' must name one of the scene's VOI scenarios."));
    AssertThrow(!study.contact_points.empty(),
                ExcMessage(study_file + ": 'Study/Contact points' must list at least one point inside the VOI."));
    std::sort(study.mode_counts.begin(), study.mode_counts.end());
    std::sort(study.force_levels.begin(), study.force_levels.end());
    for (const double force : study.force_levels)
      AssertThrow(force > 0., ExcMessage(study_file + ": 'Study/Force levels' must be positive forces in N, not " +
                                         number(force) + "."));
    return study;
  }


  void set_entry(dealii::ParameterHandler &prm, const std::string &subsection, const std::string &entry,
                 const std::string &value)
  {
    prm.enter_subsection(subsection);
    prm.set(entry, value);
    prm.leave_subsection();
  }

  // The scene's parameters with the point's settings in place, checked as any .prm is. Graded points
  // keep only the studied VOI (it becomes space 1); uniform and reference points keep none.
  SceneParameters scene_for_point(dealii::ParameterHandler &prm, const StudyParameters &study,
                                  const PointSettings &point, const std::string &output_directory)
  {
    declare_scene_parameters(prm);
    prm.parse_input(study.scene_file);
    bool found = false;
    for (unsigned int s = 1; s <= max_scenarios; ++s)
      {
        const std::string section = "Scenario " + std::to_string(s);
        prm.enter_subsection(section);
        const bool studied = prm.get("Name") == study.scenario;
        found              = found || studied;
        if (studied && point.mesh == "graded")
          prm.set("Fine size", number(point.fine_size));
        else
          prm.set("Name", "");
        prm.leave_subsection();
      }
    AssertThrow(found, ExcMessage(study.study_file + ": 'Study/Scenario' = '" + study.scenario +
                                  "' is not a scenario of " + study.scene_file + "."));
    set_entry(prm, "Meshing", "Coarse size", number(point.mesh == "graded" ? point.coarse_size : point.fine_size));
    set_entry(prm, "Meshing", "Element degree", std::to_string(point.degree));
    for (const auto entry : {"Maximum number of modes", "Minimum number of modes"})
      set_entry(prm, "Modes", entry, std::to_string(point.modes));
    set_entry(prm, "Modes", "Cut-off rule", "none");
    set_entry(prm, "Modes", "Eigensolver", point.eigensolver == "arpack-umfpack" ? "arpack" : point.eigensolver);
    set_entry(prm, "Modes", "Operator", point.eigensolver == "arpack-umfpack" ? "umfpack" : "cholmod");
    set_entry(prm, "Contact", "Patch radius", number(point.patch_radius));
    set_entry(prm, "Contact", "Validation points", study.contact_points);
    set_entry(prm, "Contact", "Validation samples", "0");
    set_entry(prm, "Contact", "Global candidate stride", "0");
    set_entry(prm, "Output", "VTU modes", "0");
    // The force axis: the reference alone solves the nonlinear problem at the contacts.
    const bool force_axis = point.mesh == "reference" && !study.force_levels.empty();
    set_entry(prm, "Contact", "Validity analysis", force_axis ? "true" : "false");
    set_entry(prm, "Contact", "Validity estimate", "false"); // the map is not what a study point measures
    if (force_axis)
      {
        const auto &d = study.push_direction;
        set_entry(prm, "Contact", "Validity direction", number(d[0]) + ", " + number(d[1]) + ", " + number(d[2]));
        set_entry(prm, "Contact", "Force limit", number(study.force_levels.back()));
      }
    return parse_scene_parameters(prm, study.scene_file, output_directory);
  }

  // The modal-only compliance with the first r modes: B_r Lambda_r^-1 B_r^T.
  Compliance modal_compliance(const ModalSpaceResult &space, const unsigned int candidate, const unsigned int r)
  {
    const unsigned int r_all = space.eigenvalues.size();
    const double      *B     = &space.candidate_modes[std::size_t(3) * candidate * r_all];
    Compliance         G{};
    for (unsigned int i = 0; i < 3; ++i)
      for (unsigned int j = 0; j < 3; ++j)
        for (unsigned int k = 0; k < r; ++k)
          G[3 * i + j] += B[i * r_all + k] * B[j * r_all + k] * static_gain(space.eigenvalues[k]);
    return G;
  }

  std::vector<Contact> find_contacts(const SceneParameters &scene, const PrecomputeResults &results,
                                     const ModalSpaceResult &space, const std::array<double, 3> &direction)
  {
    std::vector<Contact> contacts;
    for (const auto &point : scene.contact.validation_points)
      {
        Contact contact;
        contact.vertex = nearest_display_vertex(results.display, point, scene.length_unit);
        const auto it  = std::lower_bound(space.candidates.begin(), space.candidates.end(), contact.vertex);
        AssertThrow(results.display.region[contact.vertex] == space.index && it != space.candidates.end() &&
                      *it == contact.vertex,
                    ExcMessage("Study contact point (" + number(point[0]) + ", " + number(point[1]) + ", " +
                               number(point[2]) + ") does not lie in the studied space '" + space.name +
                               "': 'Study/Contact points' must lie inside the studied VOI."));
        contact.candidate = it - space.candidates.begin();
        contact.direction = direction;
        contact.full      = space.full_compliance.at(contact.vertex);
        contact.corrected = modal_compliance(space, contact.candidate, space.eigenvalues.size());
        for (unsigned int k = 0; k < 9; ++k)
          contact.corrected[k] += space.candidate_compliance[9 * std::size_t(contact.candidate) + k];
        contacts.push_back(contact);
      }
    return contacts;
  }

  // The whole results with every space cut to at most r modes and the transfers between them redone.
  PrecomputeResults truncated_results(const PrecomputeResults &results, const unsigned int r)
  {
    PrecomputeResults truncated;
    truncated.meshes  = results.meshes;
    truncated.display = results.display;
    truncated.tasks   = results.tasks;
    for (const auto &space : results.spaces)
      truncated.spaces.push_back(truncate_modal_space(space, std::min<unsigned int>(r, space.eigenvalues.size())));
    truncated.transfers = compute_transfer_matrices(truncated.display, truncated.spaces);
    truncated.timings_s = results.timings_s;
    return truncated;
  }

  class ModalStudy
  {
  public:
    ModalStudy(const StudyParameters &study, const std::string &output_directory, const bool verbose)
      : study(study), output_directory(output_directory), verbose(verbose)
    {}

    void run()
    {
      fs::create_directories(output_directory + "/points");
      for (const double rho : study.patch_radii)
        references.push_back(compute_reference(rho));
      write_reference_table(output_directory, references);
      const auto points = study_points();
      for (std::size_t k = 0; k < points.size(); ++k)
        {
          std::cout << "[study] point " << k + 1 << "/" << points.size() << ": " << points[k].label() << std::endl;
          evaluate_point(points[k]);
          write_study_table(output_directory, rows, study.force_levels); // after every point: a long study that stops keeps what it measured
        }
    }

  private:
    std::vector<PointSettings> study_points() const
    {
      std::vector<PointSettings> points;
      for (const double rho : study.patch_radii)
        for (const auto &solver : study.eigensolvers)
          for (const unsigned int degree : study.degrees)
            {
              PointSettings point;
              point.degree = degree, point.patch_radius = rho, point.eigensolver = solver;
              point.modes = study.mode_counts.back();
              point.mesh = "graded";
              for (const double fine : study.fine_sizes)
                for (const double coarse : study.coarse_sizes)
                  if (fine < coarse)
                    {
                      point.fine_size = fine, point.coarse_size = coarse;
                      points.push_back(point);
                    }
              point.mesh = "uniform";
              for (const double size : study.uniform_sizes)
                {
                  point.fine_size = point.coarse_size = size;
                  points.push_back(point);
                }
            }
      return points;
    }

    // Runs the pipeline for one point into points/<label>/ and hands back the scene and the results.
    std::pair<SceneParameters, PrecomputeResults> run_pipeline(const PointSettings &point) const
    {
      const std::string        directory = output_directory + "/points/" + point.label();
      dealii::ParameterHandler prm;
      const SceneParameters    scene = scene_for_point(prm, study, point, directory);
      ModalPrecompute          precompute(scene, prm, verbose);
      precompute.run();
      return {scene, precompute.get_results()};
    }

    ReferenceSolution compute_reference(const double rho) const
    {
      PointSettings point;
      point.mesh = "reference", point.degree = 2, point.patch_radius = rho;
      point.fine_size = point.coarse_size = study.reference_size;
      point.modes = study.reference_modes;
      std::cout << "[study] reference: " << point.label() << std::endl;
      const auto [scene, results] = run_pipeline(point);
      const auto &space = results.spaces.front();
      ReferenceSolution reference;
      reference.patch_radius   = rho;
      reference.n_dofs         = space.n_dofs;
      reference.seconds        = results.timings_s.at("total");
      reference.contacts       = find_contacts(scene, results, space, study.push_direction);
      reference.frequencies_hz = space.frequencies_hz;
      if (!study.force_levels.empty())
        reference.curves = nonlinear_curves(space, reference.contacts);
      std::cout << "[study] reference: " << space.n_dofs << " DoFs, " << reference.seconds << " s, f1 = "
                << reference.frequencies_hz.front() << " Hz" << std::endl;
      return reference;
    }

    // The reference's nonlinear solve at each contact (its validity analysis), in the contacts' order.
    std::vector<ValidityCurve> nonlinear_curves(const ModalSpaceResult &space, const std::vector<Contact> &contacts) const
    {
      std::vector<ValidityCurve> curves;
      for (const auto &contact : contacts)
        {
          const auto solved = std::find_if(space.validity.begin(), space.validity.end(),
                                           [&](const ValidityCurve &c) { return c.vertex == contact.vertex; });
          AssertThrow(solved != space.validity.end(),
                      ExcMessage(study.study_file + ": the reference has no nonlinear solve at display vertex " +
                                 std::to_string(contact.vertex) + " ('Study/Force levels' needs a part held "
                                 "against every rigid motion)."));
          const ValidityCurve &curve = *solved;
          std::cout << "[study] reference: nonlinear at vertex " << contact.vertex << ": " << curve.forces.size()
                    << " load levels up to " << curve.force_reached << " N"
                    << (curve.stop_reason.empty() ? "" : " (" + curve.stop_reason + ")") << std::endl;
          curves.push_back(curve);
        }
      return curves;
    }

    // |c / c_nonlinear(F) - 1| at each force level, the largest over the contacts (NaN where the
    // reference did not carry F at some contact).
    std::vector<double> errors_at_forces(const ReferenceSolution &reference, const std::vector<double> &felt) const
    {
      std::vector<double> errors;
      for (const double force : study.force_levels)
        {
          double worst = 0.;
          for (std::size_t k = 0; k < felt.size() && !std::isnan(worst); ++k)
            {
              const double nonlinear = secant_compliance(reference.curves[k], force);
              worst = std::isnan(nonlinear) ? nonlinear : std::max(worst, std::abs(felt[k] / nonlinear - 1.));
            }
          errors.push_back(worst);
        }
      return errors;
    }

    const ReferenceSolution &reference_for(const double rho) const
    {
      return *std::find_if(references.begin(), references.end(), [&](const auto &r) { return r.patch_radius == rho; });
    }

    // The r values of a point: the study's counts, then what each cut-off rule keeps.
    std::vector<std::pair<std::string, unsigned int>> mode_counts(const SceneParameters &scene,
                                                                  const ModalSpaceResult &space) const
    {
      std::vector<std::pair<std::string, unsigned int>> counts;
      for (const unsigned int r : study.mode_counts)
        counts.emplace_back("count", r);
      for (const auto &rule : study.cut_off_rules)
        {
          ModeParameters modes = scene.modes;
          modes.cut_off_rule   = rule == "display" ? CutOffRule::display : CutOffRule::haptic;
          const double cut_off = modes.cut_off_frequency();
          const auto   below   = std::count_if(space.frequencies_hz.begin(), space.frequencies_hz.end(),
                                             [&](const double f) { return f <= cut_off; });
          counts.emplace_back(rule, std::max<unsigned int>(1, below));
        }
      return counts;
    }

    void evaluate_point(const PointSettings &point)
    {
      const auto [scene, results] = run_pipeline(point);
      const unsigned int studied  = point.mesh == "graded" ? 1 : 0;
      const auto        &space    = results.spaces.at(studied);
      const auto         contacts = find_contacts(scene, results, space, study.push_direction);
      const auto        &reference = reference_for(point.patch_radius);

      StudyRow common;
      common.point      = point;
      common.n_dofs     = space.n_dofs;
      common.candidates = space.candidates.size();
      common.seconds = phase_seconds(results, studied);
      common.correction_ms_per_candidate = 1e3 * space.correction_seconds_per_candidate;
      compare_frequencies(space, reference, common);
      for (std::size_t k = 0; k < contacts.size(); ++k)
        {
          const auto &contact = contacts[k], &exact = reference.contacts[k];
          const double ref = along(exact.full, contact.direction);
          common.corrected_felt_compliance.push_back(along(contact.corrected, contact.direction));
          common.felt_error_corrected =
            std::max(common.felt_error_corrected, std::abs(along(contact.corrected, contact.direction) - ref) / ref);
          common.felt_error_corrected_3x3 = std::max(common.felt_error_corrected_3x3,
                                                     frobenius_distance(contact.corrected, exact.full) / frobenius_norm(exact.full));
          common.correction_residual = std::max(common.correction_residual,
                                                frobenius_distance(contact.corrected, contact.full) / frobenius_norm(contact.full));
        }
      if (!study.force_levels.empty())
        common.felt_error_corrected_at_force = errors_at_forces(reference, common.corrected_felt_compliance);

      // The .mrt and the kernel's cost depend on r alone: a cut-off rule that keeps one of the
      // counted r reuses its measurement.
      std::map<unsigned int, std::pair<std::uintmax_t, KernelCost>> measured;
      for (const auto &[rule, r_wanted] : mode_counts(scene, space))
        {
          StudyRow row = common;
          row.r_rule   = rule;
          row.r        = std::min<unsigned int>(r_wanted, space.eigenvalues.size());
          std::vector<double> modal_felt;
          for (std::size_t k = 0; k < contacts.size(); ++k)
            {
              const auto  &contact = contacts[k];
              const auto   modal   = modal_compliance(space, contact.candidate, row.r);
              const double ref     = along(reference.contacts[k].full, contact.direction);
              const double felt    = along(modal, contact.direction);
              modal_felt.push_back(felt);
              row.felt_error_modal = std::max(row.felt_error_modal, std::abs(felt - ref) / ref);
              row.felt_error_modal_3x3 =
                std::max(row.felt_error_modal_3x3, frobenius_distance(modal, reference.contacts[k].full) /
                                                     frobenius_norm(reference.contacts[k].full));
              const double own = along(contact.full, contact.direction);
              row.truncation_error = std::max(row.truncation_error, std::abs(felt - own) / own);
            }
          if (!study.force_levels.empty())
            row.felt_error_modal_at_force = errors_at_forces(reference, modal_felt);
          for (const auto &vc : space.validation)
            if (std::any_of(contacts.begin(), contacts.end(), [&](const auto &c) { return c.vertex == vc.vertex; }))
              row.display_error_modal = std::max(row.display_error_modal, vc.field_rel_error_by_modes.at(row.r - 1));
          if (measured.count(row.r) == 0)
            {
              measure_basis_file(results, scene, row, contacts.front());
              measured[row.r] = {row.mrt_bytes, row.kernel};
            }
          std::tie(row.mrt_bytes, row.kernel) = measured[row.r];
          rows.push_back(row);
          std::cout << "[study]   r = " << std::setw(4) << row.r << " (" << rule << "): felt error modal "
                    << std::setprecision(3) << 100 * row.felt_error_modal << " %, corrected "
                    << 100 * row.felt_error_corrected << " %, tick " << row.kernel.tick_p50_ns << " / "
                    << row.kernel.corrected_tick_p50_ns << " ns" << std::setprecision(6) << std::endl;
        }
      // Each point's .h5 and modes are not needed once measured: keep the report and the parameters.
      for (const auto &entry : fs::directory_iterator(scene.output_directory))
        if (entry.path().extension() == ".h5" || entry.path().extension() == ".vtu" || entry.path().extension() == ".mrt")
          fs::remove(entry.path());
    }

    // The seconds of the studied space's meshing and phases, and their total.
    static std::map<std::string, double> phase_seconds(const PrecomputeResults &results, const unsigned int studied)
    {
      const auto                   &space = results.spaces.at(studied);
      std::map<std::string, double> seconds;
      seconds["meshing"] = results.meshes.scenarios[studied].statistics.seconds +
                           results.meshes.display_surface.statistics.seconds;
      seconds["total"] = seconds["meshing"];
      for (const auto phase : {"assembly", "eigensolve", "static_correction", "validation"})
        {
          seconds[phase] = space.timings_s.count(phase) ? space.timings_s.at(phase) : 0.;
          seconds["total"] += seconds[phase];
        }
      return seconds;
    }

    void compare_frequencies(const ModalSpaceResult &space, const ReferenceSolution &reference, StudyRow &row) const
    {
      row.frequencies_compared = std::min(space.frequencies_hz.size(), reference.frequencies_hz.size());
      for (unsigned int i = 0; i < row.frequencies_compared; ++i)
        {
          const double error = std::abs(space.frequencies_hz[i] - reference.frequencies_hz[i]) / reference.frequencies_hz[i];
          row.frequency_error_max = std::max(row.frequency_error_max, error);
          if (i == 0)
            row.frequency_error_first = error;
        }
    }

    // The .mrt of the point cut to r modes: its size and the kernel's cost on it.
    void measure_basis_file(const PrecomputeResults &results, const SceneParameters &scene, StudyRow &row,
                            const Contact &contact) const
    {
      const std::string file = scene.output_directory + "/study_r" + std::to_string(row.r) + ".mrt";
      StagedFiles staged;
      write_basis_file(file, scene, truncated_results(results, row.r), staged);
      staged.commit();
      row.mrt_bytes = fs::file_size(file);
      row.kernel    = measure_kernel(file, contact, study.kernel_ticks);
      fs::remove(file);
    }

    const StudyParameters         &study;
    const std::string              output_directory;
    const bool                     verbose;
    std::vector<ReferenceSolution> references;
    std::vector<StudyRow>          rows;
  };
} // namespace modal_haptics

int main(int argc, char **argv)
{
  using namespace modal_haptics;
  apply_openblas_settings(argv);
  // deal.II's default thread count: the node's cores shared among its MPI processes (2 for one
  // process on 2 cores, 1 each under mpirun -np 2). DEAL_II_NUM_THREADS lowers it. The triangular
  // solves and the M products run on these threads.
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv);
  std::string study_file, output_directory;
  bool        report = true, verbose = false;
  for (int i = 1; i < argc; ++i)
    {
      const std::string arg = argv[i];
      if (arg == "--no-report")
        report = false;
      else if (arg == "--verbose")
        verbose = true;
      else if (arg == "--output-dir" && i + 1 < argc)
        output_directory = argv[++i];
      else if (arg == "--help" || arg == "-h")
        {
          std::cout << "usage: modal-study STUDY.prm [--output-dir DIR] [--no-report] [--verbose]\n\n";
          dealii::ParameterHandler prm;
          declare_study_parameters(prm);
          prm.print_parameters(std::cout, dealii::ParameterHandler::Text);
          return 0;
        }
      else if (!arg.empty() && arg[0] != '-' && study_file.empty())
        study_file = arg;
      else
        {
          std::cerr << "modal-study: unknown or incomplete argument '" << arg << "'\n"
                    << "usage: modal-study STUDY.prm [--output-dir DIR] [--no-report] [--verbose]" << std::endl;
          return 2;
        }
    }
  if (study_file.empty())
    {
      std::cerr << "usage: modal-study STUDY.prm [--output-dir DIR] [--no-report] [--verbose]" << std::endl;
      return 2;
    }
  try
    {
      const StudyParameters study = read_study_parameters(study_file);
      if (output_directory.empty())
        output_directory = "results/study_" + fs::path(study_file).stem().string();
      dealii::Timer total;
      ModalStudy(study, output_directory, verbose).run();
      std::cout << "[study] done in " << total.wall_time() << " s: " << output_directory << "/study.csv" << std::endl;
      if (report && write_report(output_directory) != 0)
        {
          std::cerr << "modal-study: scripts/study_report.py failed; study.csv is complete" << std::endl;
          return 1;
        }
    }
  catch (const dealii::ExceptionBase &e)
    {
      std::ostringstream message;
      e.print_info(message);
      std::cerr << "modal-study: error\n" << message.str() << std::endl;
      return 1;
    }
  catch (const std::exception &e)
    {
      std::cerr << "modal-study: error\n" << e.what() << std::endl;
      return 1;
    }
  return 0;
}
