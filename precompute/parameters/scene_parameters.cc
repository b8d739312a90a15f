#include "parameters/scene_parameters.h"

#include "parameters/parameter_messages.h"
#include "parameters/parameter_sections.h"
#include "parameters/parameter_text.h"
#include "parameters/variant_parameters.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <set>
#include <sstream>

namespace modal_haptics
{
  using dealii::ExcMessage;
  using dealii::ParameterHandler;
  using parameter_messages::OpenInterval;
  using parameter_text::Notation;
  using parameter_text::text;
  namespace Patterns = dealii::Patterns;

  namespace
  {
    const std::array<std::pair<EigensolverKind, const char *>, 4> eigensolver_names = {
      {{EigensolverKind::automatic, "auto"},
       {EigensolverKind::block_krylov, "block-krylov"},
       {EigensolverKind::arpack, "arpack"},
       {EigensolverKind::lobpcg_amg, "lobpcg-amg"}}};

    const std::array<std::pair<FactorStorage, const char *>, 3> factor_storage_names = {
      {{FactorStorage::automatic, "auto"}, {FactorStorage::memory, "memory"}, {FactorStorage::disk, "disk"}}};

    const char *factor_storage_name(const FactorStorage storage)
    {
      for (const auto &[kind, name] : factor_storage_names)
        if (kind == storage)
          return name;
      return "?";
    }
  }

  std::string eigensolver_name(const EigensolverKind kind)
  {
    for (const auto &[k, name] : eigensolver_names)
      if (k == kind)
        return name;
    return "?";
  }

  EigensolverKind eigensolver_kind(const std::string &name)
  {
    for (const auto &[kind, spelling] : eigensolver_names)
      if (name == spelling)
        return kind;
    AssertThrow(false, ExcMessage("'Modes/Eigensolver' is '" + name + "': not one of auto, block-krylov, arpack, lobpcg-amg."));
    return EigensolverKind::automatic;
  }

  double ModeParameters::cut_off_frequency() const
  {
    switch (cut_off_rule)
      {
        case CutOffRule::display:
          return display_rate / 2.;
        case CutOffRule::haptic:
          return haptic_rate / 2.;
        case CutOffRule::none:
        default:
          return std::numeric_limits<double>::infinity();
      }
  }

  double DampingParameters::ratio(const double omega) const
  {
    if (!rayleigh)
      return modal_ratio;
    // Rayleigh damping C = alpha M + beta K gives zeta = alpha / (2 omega) + beta omega / 2; a rigid
    // mode (omega = 0) with alpha > 0 is infinitely over-damped, which we cap.
    if (omega <= 0.)
      return alpha > 0. ? 1e6 : 0.;
    return alpha / (2. * omega) + beta * omega / 2.;
  }

  using namespace parameter_sections;

  // ---- The precompute's structs --------------------------------------------------------------------
  void MaterialParameters::declare_parameters(ParameterHandler &prm)
  {
    const MaterialParameters m;
    prm.enter_subsection("Material");
    prm.declare_entry("Young's modulus", text(m.youngs_modulus), OpenInterval(0.),
                      "Young's modulus E (> 0). ABS: 2.3e9. Units: Pa.");
    prm.declare_entry("Poisson's ratio", text(m.poissons_ratio), OpenInterval(-1., 0.5),
                      "Poisson's ratio nu, in (-1, 0.5). Units: none.");
    prm.declare_entry("Density", text(m.density), OpenInterval(0.), "Mass density rho (> 0). Units: kg/m^3.");
    prm.leave_subsection();
  }

  void MaterialParameters::parse_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Material");
    youngs_modulus = prm.get_double("Young's modulus");
    poissons_ratio = prm.get_double("Poisson's ratio");
    density        = prm.get_double("Density");
    prm.leave_subsection(); // the Patterns hold the open ranges: the parser refuses what lies outside
  }

  namespace
  {
    const char *cut_off_rule_name(const CutOffRule rule)
    {
      return rule == CutOffRule::none ? "none" : rule == CutOffRule::display ? "display" : "haptic";
    }
  } // namespace

  namespace
  {
    // 'Modes': how many modes, the cut-off, the shift and the eigensolver (m: the defaults).
    void declare_eigensolver_entries(ParameterHandler &prm, const ModeParameters &m)
    {
      prm.declare_entry("Maximum number of modes", text(m.maximum_count), Patterns::Integer(1),
                        "The eigensolve computes at most this many lowest modes (r, >= 1); with a cut-off rule it "
                        "stops once the rule's count is decided (the minimum and one converged mode above the "
                        "cut-off): the block Krylov method as its Ritz pairs converge, ARPACK (PARPACK) and LOBPCG "
                        "after a first run for the minimum and a margin (half the minimum, at least 4), then runs "
                        "that double the count found, each in the complement of the modes found before. Units: none.");
      prm.declare_entry("Minimum number of modes", text(m.minimum_count), Patterns::Integer(0),
                        "The cut-off never leaves fewer modes than this. The default (" + text(m.minimum_count) +
                          ") is lowered to 'Maximum number of modes' when that is smaller. Units: none.");
      prm.declare_entry("Cut-off rule", cut_off_rule_name(m.cut_off_rule), Patterns::Selection("none|display|haptic"),
                        "Which modes are dropped: 'display' drops modes above half the display rate (the "
                        "original method: no temporal aliasing on screen), 'haptic' above half the haptic "
                        "rate (the haptic loop's Nyquist frequency), 'none' keeps all. Units: none.");
      prm.declare_entry("Display rate", text(m.display_rate), Patterns::Double(1e-3), "Display frame rate. Units: Hz.");
      prm.declare_entry("Haptic rate", text(m.haptic_rate), Patterns::Double(1e-3), "Haptic loop rate. Units: Hz.");
      prm.declare_entry("Shift", text(m.shift), Patterns::Double(),
                        "Shift of the shift-invert transformation, as a frequency; must lie below the first "
                        "frequency, and below zero for a free-floating part (no clamp groups), where a "
                        "magnitude of about a tenth of the first elastic frequency is best: the static solves "
                        "refine with the shifted factorization and gain a factor (shift / f1)^2 per step. "
                        "Negative values mean -(2 pi |shift|)^2. Units: Hz.");
      prm.declare_entry("Tolerance", text(m.tolerance), Patterns::Double(1e-16, 1e-2),
                        "ARPACK's relative tolerance on the Ritz values. Units: none.");
      prm.declare_entry("Eigensolver", eigensolver_name(m.eigensolver), Patterns::Selection("auto|block-krylov|arpack|lobpcg-amg"),
                        "'block-krylov': a block Krylov method on the shift-invert operator (a sparse direct "
                        "factorization of K - shift M; blocks of 'Block size' right-hand sides per solve, thick "
                        "restarts). 'arpack': ARPACK's dsaupd on the same operator, one vector per solve. "
                        "'lobpcg-amg': LOBPCG (Trilinos Anasazi) preconditioned by smoothed-aggregation AMG "
                        "(Trilinos ML, the rigid-body motions as its near-null space), static solves by AMG-"
                        "preconditioned block CG (Trilinos Belos) deflated by the modes: no factorization, memory about linear in the DoFs, for parts whose "
                        "factor does not fit (serial and under mpirun). 'auto': block-krylov when CHOLMOD's analysis says its "
                        "factor fits in 'Factor memory limit', else MUMPS on this one process, its factor in memory or "
                        "on disk ('Factor storage'), else lobpcg-amg (also where MUMPS cannot serve: 'Factor storage = "
                        "memory', a part with free rigid-body motions). Under mpirun MUMPS factorizes: "
                        "'block-krylov' and 'arpack' (PARPACK) over it, 'auto' the block Krylov method when MUMPS's "
                        "analysis says its factor fits, in memory or on disk, else lobpcg-amg. All converge to the same modes. Units: none.");
      prm.declare_entry("LOBPCG tolerance", text(m.lobpcg_tolerance), Patterns::Double(1e-14, 1e-2),
                        "lobpcg-amg: converged when every wanted pair's ||(K - shift M) x - theta M x|| / "
                        "(theta ||M x||) is below this (theta: the pair's eigenvalue of K - shift M). The eigenvalues' relative "
                        "error is about its square: 1e-6 gave frequencies equal to the direct path's to 5e-11; "
                        "below about 1e-8 rounding stalls LOBPCG. Units: none.");
      prm.declare_entry("LOBPCG modes per run", text(m.lobpcg_modes_per_run), Patterns::Integer(0),
                        "lobpcg-amg: the most modes one LOBPCG run seeks; more modes are found by further runs, "
                        "each in the M-orthogonal complement of the modes found before (smaller blocks, so less "
                        "memory, but more iterations: 1.2x the time for two runs of 25 on a P2 plate). 0: all at "
                        "once when that run fits half the memory available (per process), else as many as fit. "
                        "Units: none.");
    }

    // 'Modes': the direct factorization, its memory and where its factor is kept.
    void declare_factorization_entries(ParameterHandler &prm, const ModeParameters &m)
    {
      prm.declare_entry("Factor memory limit", text(m.factor_memory_limit), Patterns::Double(0.),
                        "The largest direct factor (as CHOLMOD's analysis predicts it) that a serial run computes in "
                        "memory: a larger one goes to MUMPS on this process ('Factor storage = auto'), or to "
                        "lobpcg-amg ('Eigensolver = auto' where MUMPS cannot take it). Under mpirun the limit of a node's processes "
                        "together, each held to its share against MUMPS's prediction of its in-core data (the "
                        "symmetric mode; the LU always factorizes). The same limit decides whether the distributed "
                        "path's MUMPS factor stays in memory ('Factor storage = auto') and whether the block Krylov "
                        "method keeps M V beside its bases V and OP V (else recomputed: a third less memory). 0: "
                        "half the memory available when the space is solved. Units: GB (1e9 bytes).");
      prm.declare_entry("Block size", text(m.block_size), Patterns::Integer(1, 64),
                        "Right-hand sides per solve of the block Krylov eigensolver. Units: none.");
      prm.declare_entry("Operator", m.factorization_kind == FactorizationKind::umfpack ? "umfpack" : "cholmod",
                        Patterns::Selection("cholmod|umfpack"),
                        "Factorization behind the shift-invert operator: 'cholmod' (SuiteSparse supernodal "
                        "Cholesky, METIS ordering) or 'umfpack' (deal.II's LU, slow, a peer only). Units: none.");
      prm.declare_entry("Distributed factorization",
                        m.distributed_factorization == DistributedFactorizationKind::mumps_lu ? "mumps-lu" : "mumps-cholesky",
                        Patterns::Selection("mumps-cholesky|mumps-lu"),
                        "Under mpirun (the distributed path), the factorization of K - shift M: 'mumps-cholesky' "
                        "(MUMPS in its symmetric mode, L D L^T, through its C interface with METIS's node ordering: about "
                        "half the factor and the flops of an LU) or 'mumps-lu' (MUMPS's LU through Trilinos Amesos, a peer). Units: none.");
      prm.declare_entry("Factor storage", factor_storage_name(m.factor_storage), Patterns::Selection("auto|memory|disk"),
                        "Where MUMPS keeps its factor (under mpirun, with --distributed, or on a serial run that hands a "
                        "space to MUMPS). "
                        "'memory': in core. 'disk': out of core, in 'Factor directory' (MUMPS writes the factor "
                        "once and reads it back at every block solve; its in-core data shrinks to the fronts being "
                        "worked on, so parts whose factor exceeds the memory still take the direct path). 'auto': "
                        "in memory when MUMPS's analysis predicts in-core data within 'Factor memory limit', else "
                        "on disk; with 'Eigensolver = auto', lobpcg-amg only when even the out-of-core data "
                        "would not fit. A serial run keeps CHOLMOD's factor in memory and hands a space to MUMPS on its "
                        "one process with 'disk', or with 'auto' when CHOLMOD's factor would exceed 'Factor memory "
                        "limit' (not a part with free rigid-body motions, which MUMPS's path does not take). 'memory' "
                        "keeps a serial run on CHOLMOD. Units: none.");
      prm.declare_entry("Factor directory", m.factor_directory, Patterns::Anything(),
                        "Factor storage = disk (or auto, out of core): the directory of MUMPS's factor files, "
                        "each process's in its own subdirectory, removed when the space is done (a killed run's by "
                        "the next run on the host). Empty: $MUMPS_OOC_TMPDIR, else $TMPDIR, else /tmp. "
                        "Units: none (a path).");
    }
  } // namespace

  void ModeParameters::declare_parameters(ParameterHandler &prm)
  {
    const ModeParameters m;
    prm.enter_subsection("Modes");
    declare_eigensolver_entries(prm, m);
    declare_factorization_entries(prm, m);
    prm.leave_subsection();
  }

  void ModeParameters::parse_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Modes");
    maximum_count = prm.get_integer("Maximum number of modes");
    minimum_count = prm.get_integer("Minimum number of modes");
    const std::string rule = prm.get("Cut-off rule");
    cut_off_rule   = rule == "none" ? CutOffRule::none : rule == "display" ? CutOffRule::display : CutOffRule::haptic;
    display_rate   = prm.get_double("Display rate");
    haptic_rate    = prm.get_double("Haptic rate");
    shift          = prm.get_double("Shift");
    tolerance      = prm.get_double("Tolerance");
    factorization_kind = prm.get("Operator") == "umfpack" ? FactorizationKind::umfpack : FactorizationKind::cholmod;
    distributed_factorization = prm.get("Distributed factorization") == "mumps-lu" ?
                                  DistributedFactorizationKind::mumps_lu :
                                  DistributedFactorizationKind::mumps_cholesky;
    eigensolver    = eigensolver_kind(prm.get("Eigensolver"));
    lobpcg_tolerance = prm.get_double("LOBPCG tolerance");
    lobpcg_modes_per_run = prm.get_integer("LOBPCG modes per run");
    factor_memory_limit = prm.get_double("Factor memory limit");
    block_size     = prm.get_integer("Block size");
    for (const auto &[kind, name] : factor_storage_names) // the pattern admits only these names
      if (prm.get("Factor storage") == name)
        factor_storage = kind;
    factor_directory = prm.get("Factor directory");
    prm.leave_subsection();
    // The default minimum follows a smaller requested count: asking for 5 modes must not fail on a
    // default nobody wrote. A minimum written above the maximum is still an error.
    if (minimum_count == ModeParameters().minimum_count && maximum_count < minimum_count)
      minimum_count = maximum_count;
    AssertThrow(minimum_count <= maximum_count,
                ExcMessage("'Modes/Minimum number of modes' = " + text(minimum_count) +
                           " exceeds 'Maximum number of modes' = " + text(maximum_count) + "."));
    // Said here, where --validate sees it; 'auto' switching to lobpcg-amg is checked where it does.
    AssertThrow(eigensolver != EigensolverKind::lobpcg_amg || shift <= 0.,
                ExcMessage("'Modes/Eigensolver = lobpcg-amg' needs 'Modes/Shift' <= 0 (K - shift M must be positive "
                           "definite for the AMG and CG); it is " + text(shift) + " Hz."));
  }

  void DampingParameters::declare_parameters(ParameterHandler &prm)
  {
    const DampingParameters d;
    prm.enter_subsection("Damping");
    prm.declare_entry("Model", d.rayleigh ? "rayleigh" : "modal", Patterns::Selection("rayleigh|modal"),
                      "'rayleigh': C = alpha M + beta K (damping ratio alpha / (2 omega) + beta omega / 2); "
                      "'modal': one damping ratio for every mode. A kept mode damped above 0.5 is warned about: it "
                      "barely oscillates, so it is not felt as a vibration. Units: none.");
    prm.declare_entry("Rayleigh alpha", text(d.alpha), Patterns::Double(0.), "Mass-proportional coefficient. Units: 1/s.");
    prm.declare_entry("Rayleigh beta", text(d.beta), Patterns::Double(0.), "Stiffness-proportional coefficient. Units: s.");
    prm.declare_entry("Modal damping ratio", text(d.modal_ratio), Patterns::Double(0.),
                      "Damping ratio zeta. Units: none.");
    prm.leave_subsection();
  }

  void DampingParameters::parse_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Damping");
    rayleigh    = prm.get("Model") == "rayleigh";
    alpha       = prm.get_double("Rayleigh alpha");
    beta        = prm.get_double("Rayleigh beta");
    modal_ratio = prm.get_double("Modal damping ratio");
    prm.leave_subsection();
  }

  namespace
  {
    // 'Contact': the patch, the candidates, the cross compliance, the far field and the validation (c: the defaults).
    void declare_contact_entries(ParameterHandler &prm, const ContactParameters &c)
    {
      prm.declare_entry("Patch radius", text(c.patch_radius), Patterns::Double(0.),
                        "Radius rho of the contact patch over which a HIP's force is spread (0: single-vertex "
                        "load)." + geometry_units);
      prm.declare_entry("Global candidate stride", text(c.global_candidate_stride), Patterns::Integer(0),
                        "Static-correction candidates (corrected contacts) of the global space: every n-th display "
                        "vertex outside every VOI (1: all of them, the default); 0 = none. A HIP at a vertex "
                        "that is not a candidate feels the modes alone. Units: none.");
      prm.declare_entry("Global candidates in VOIs", text(c.global_candidates_in_vois), Patterns::Bool(),
                        "The global space corrects every display vertex inside every VOI too (true, the default): "
                        "the kernel switches to the global space when HIPs touch two regions no scenario holds "
                        "together, and a contact there then stays exact instead of falling to the modes alone. "
                        "A validation point inside a VOI is then solved afresh in the global space too. Costs "
                        "static-correction time and .mrt size (docs/accuracy.md). Units: none.");
      prm.declare_entry("Maximum candidates", text(c.maximum_candidates), Patterns::Integer(1),
                        "At most this many candidates per space (thinned evenly); the default takes every "
                        "display vertex of the space's region. Units: none.");
      prm.declare_entry("Cross compliance", text(c.cross_compliance), Patterns::Bool(),
                        "Store the residual compliance between pairs of candidates of a space closer than "
                        "'Cross compliance radius' (two hands on one rib). Units: none.");
      prm.declare_entry("Cross compliance radius", text(c.cross_compliance_radius), Patterns::Double(0.),
                        "Two candidates closer than this, or sharing a display triangle (radius 0, the default: "
                        "what a sliding contact blends), get their residual cross compliance stored: two HIPs "
                        "that close feel the full-FE answer; farther apart, the modes and the far field couple them "
                        "('Far field rank'; docs/accuracy.md measures what that leaves out; each millimetre costs "
                        "static-correction time and .mrt size)." + geometry_units);
      prm.declare_entry("Far field rank", text(c.far_field_rank), Patterns::Integer(0, 1000),
                        "Two candidates farther apart than the cross compliance radius are coupled by the "
                        "modes plus a rank-k approximation of the residual compliance between every pair of "
                        "candidates of the space (a Nystrom factor from 2 k solves; the .mrt's FAR_COMPLIANCE, "
                        "3 k numbers per candidate); its error against exact solves, by distance, is in "
                        "report.json (spaces[].far_field). 0 = none: the modes alone couple such pairs. Needs "
                        "'Cross compliance'. Units: none.");
      prm.declare_entry("Validation pairs", text(c.validation_pairs), Patterns::Integer(0),
                        "Pairs of neighbouring candidates per space (closer than the cross compliance radius, "
                        "picked at random with a fixed seed) pressed together and validated against one full "
                        "static FE solve; with a far field ('Far field rank'), as many pairs farther apart too "
                        "(report.json: two_contact_checks, 'far'). Units: none.");
      prm.declare_entry("Validation samples", text(c.validation_samples), Patterns::Integer(0),
                        "Candidates per space validated against full static FE, in x, y and z. Units: none.");
      prm.declare_entry("Validation points", "", Patterns::Anything(),
                        "Contact points validated in every space, 'x,y,z; x,y,z; ...': the nearest display vertex "
                        "of each becomes a static-correction candidate." + geometry_units);
      prm.declare_entry("Exact pair points", "", Patterns::Anything(),
                        "Anticipated two-contact presses, 'x,y,z : x,y,z; ...' (two hands, or two fingers, farther "
                        "apart than 'Cross compliance radius'): in every space, the residual cross compliance "
                        "between each candidate within 'Exact pair reach' of the first point (and the one nearest "
                        "to it, with the candidates sharing a display triangle with that one) and each such "
                        "candidate of the second is stored, so that two HIPs there (snapped or sliding) feel the "
                        "full-FE answer instead of the far field's; the nearest pair is validated against one full "
                        "static solve (report.json: two_contact_checks, 'named'). Needs 'Cross compliance'."
                        + geometry_units);
      prm.declare_entry("Exact pair reach", text(c.exact_pair_reach), Patterns::Double(0.),
                        "The distance from each of 'Exact pair points' within which candidates are coupled exactly "
                        "to those around the other point: a HIP's contact load spreads over its triangle's corners "
                        "(sliding) and lands near, not at, the point. 0 (the default): twice 'Patch radius', so that "
                        "it follows the model's units with the patch." + geometry_units);
    }

    // 'Contact': the correction field's tolerance and the validity analysis.
    void declare_validity_entries(ParameterHandler &prm, const ContactParameters &c)
    {
      prm.declare_entry("Correction field tolerance", text(c.correction_field_tolerance, Notation::exponent), Patterns::Double(0., 1.),
                        "The display correction field of a contact is kept where it exceeds this fraction of "
                        "its maximum (it is local); the validation reports the error this truncation leaves. "
                        "Units: none.");
      prm.declare_entry("Force limit", text(c.force_limit), Patterns::Double(0.),
                        "The largest contact force the validity analysis ramps each validation point's patch "
                        "load up to (the default is the kernel's default device force limit, device.max_force). "
                        "Units: N.");
      prm.declare_entry("Validity analysis", text(c.validity_analysis), Patterns::Bool(),
                        "At each validation point, a geometrically nonlinear full-FE solve (total Lagrangian, "
                        "Newton) of its patch load up to 'Force limit', in the space whose region holds it: "
                        "the force-displacement curve and the forces up to which the linear felt compliance "
                        "stays within 1, 5 and 10 %, and the second-order estimate there against it. Off by "
                        "default: each point costs nonlinear solves (5 tangent assemblies of up to 164k DoFs "
                        "on the default scene, about 22 CG iterations with K's factorization; its time in "
                        "docs/performance.md). Units: none.");
      prm.declare_entry("Validity material", c.validity_neo_hookean ? "neo-Hookean" : "St. Venant-Kirchhoff",
                        Patterns::Selection("neo-Hookean|St. Venant-Kirchhoff"),
                        "Hyperelastic law of the validity analysis, with the part's Young's modulus and "
                        "Poisson's ratio: compressible neo-Hookean, or St. Venant-Kirchhoff (which softens "
                        "without bound in compression). Units: none.");
      prm.declare_entry("Validity direction", "normal", Patterns::Anything(),
                        "The direction the validity analysis presses along: 'normal' (into the part, along "
                        "the display surface's normal at the contact) or a vector 'x, y, z' (normalized). "
                        "Units: none.");
      prm.declare_entry("Validity load steps", text(c.validity_load_steps), Patterns::Integer(1, 1000),
                        "The validity analysis' first load increment is 'Force limit' divided by this; an "
                        "increment is halved where Newton fails and grows where it converges fast. The "
                        "validity forces are interpolated linearly between levels (on the default scene 5 "
                        "levels give rib_b's 1 % force within 0.2 % of 10 levels'). Units: none.");
      prm.declare_entry("Validity estimate", text(c.validity_estimate), Patterns::Bool(),
                        "At every corrected contact (every display vertex with a felt stiffness), the validity "
                        "forces [N] from the second-order term of the felt force-displacement curve, the cubic "
                        "term of the stored energy ('Validity material') evaluated on the contact's linear "
                        "response projected on the space's modes (docs/accuracy.md): the validity map of the "
                        ".mrt, .h5 and validity.vtu. Its cost is a cubic tensor per space, then little per "
                        "contact (docs/performance.md), serial and under MPI; a space with free rigid motions "
                        "gets none. Units: none.");
      prm.declare_entry("Validity tangent solver", c.validity_cg ? "preconditioned CG" : "factorization",
                        Patterns::Selection("preconditioned CG|factorization"),
                        "How the validity analysis solves each Newton step's tangent system: 'preconditioned "
                        "CG' (conjugate gradients preconditioned by the space's factorization of K, the tangent "
                        "factorized only where CG stalls) or 'factorization' (every tangent factorized). "
                        "Units: none.");
    }
  } // namespace

  void ContactParameters::declare_parameters(ParameterHandler &prm)
  {
    const ContactParameters c;
    prm.enter_subsection("Contact");
    declare_contact_entries(prm, c);
    declare_validity_entries(prm, c);
    prm.leave_subsection();
  }

  void ContactParameters::parse_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Contact");
    patch_radius               = prm.get_double("Patch radius");
    global_candidate_stride    = prm.get_integer("Global candidate stride");
    global_candidates_in_vois  = prm.get_bool("Global candidates in VOIs");
    maximum_candidates         = prm.get_integer("Maximum candidates");
    cross_compliance           = prm.get_bool("Cross compliance");
    cross_compliance_radius    = prm.get_double("Cross compliance radius");
    validation_pairs           = prm.get_integer("Validation pairs");
    far_field_rank             = prm.get_integer("Far field rank");
    validation_samples         = prm.get_integer("Validation samples");
    correction_field_tolerance = prm.get_double("Correction field tolerance");
    for (const auto &point : dealii::Utilities::split_string_list(prm.get("Validation points"), ';'))
      validation_points.push_back(parse_point(point, "Contact/Validation points"));
    exact_pairs.clear();
    for (const auto &pair : dealii::Utilities::split_string_list(prm.get("Exact pair points"), ';'))
      {
        const auto ends = dealii::Utilities::split_string_list(pair, ':');
        AssertThrow(ends.size() == 2, dealii::ExcMessage("'Contact/Exact pair points': '" + pair +
                                                         "' is not a pair 'x,y,z : x,y,z'."));
        exact_pairs.push_back({{parse_point(ends[0], "Contact/Exact pair points"),
                                parse_point(ends[1], "Contact/Exact pair points")}});
      }
    exact_pair_reach = prm.get_double("Exact pair reach");
    if (exact_pair_reach == 0.)
      exact_pair_reach = 2. * patch_radius;
    AssertThrow(exact_pairs.empty() || exact_pair_reach > 0.,
                dealii::ExcMessage("'Contact/Exact pair reach' is 0 and so is 'Contact/Patch radius' (a single-vertex "
                                   "load): set the reach for 'Contact/Exact pair points' (geometry units)."));
    AssertThrow(exact_pairs.empty() || cross_compliance,
                dealii::ExcMessage("'Contact/Exact pair points' needs 'Contact/Cross compliance' = true: the pairs' "
                                   "cross blocks are stored with the cross compliance."));
    force_limit          = prm.get_double("Force limit");
    AssertThrow(force_limit > 0., dealii::ExcMessage("'Contact/Force limit' is " + prm.get("Force limit") +
                                                     " N: it must be above 0."));
    validity_analysis    = prm.get_bool("Validity analysis");
    validity_neo_hookean = prm.get("Validity material") == "neo-Hookean";
    if (const auto direction = prm.get("Validity direction"); direction != "normal")
      {
        auto d = parse_point(direction, "Contact/Validity direction");
        const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        AssertThrow(norm > 0., dealii::ExcMessage("'Contact/Validity direction' is '" + direction +
                                                  "': expected 'normal' or a nonzero vector 'x, y, z'."));
        validity_direction = meshing::Point3{{d[0] / norm, d[1] / norm, d[2] / norm}};
      }
    validity_load_steps  = prm.get_integer("Validity load steps");
    validity_estimate    = prm.get_bool("Validity estimate");
    validity_cg          = prm.get("Validity tangent solver") == "preconditioned CG";
    prm.leave_subsection();
  }

  namespace
  {
    // In the order of VtuCompression.
    const std::string vtu_compression_names[] = {"none", "fast", "best"};
  } // namespace

  void OutputParameters::declare_parameters(ParameterHandler &prm)
  {
    const OutputParameters o;
    prm.enter_subsection("Output");
    prm.declare_entry("Mode precision", o.float64_modes ? "float64" : "float32", Patterns::Selection("float32|float64"),
                      "Scalar type of the display modes in the .mrt file. Units: none.");
    prm.declare_entry("VTU modes", text(o.vtu_modes), Patterns::Integer(0), "Mode shapes written for ParaView. Units: none.");
    prm.declare_entry("VTU compression", vtu_compression_names[int(o.vtu_compression)], Patterns::Selection("none|fast|best"),
                      "The mode-shape VTU files: 'none' (the arrays appended raw, the cells sharing their "
                      "nodes' points: the smallest and fastest; docs/precompute.md), or deal.II's writer with "
                      "zlib on the data, every cell its own points: 'fast' (zlib's fastest level) or 'best' "
                      "(zlib's best: about 1.5 % smaller than 'fast'). ParaView reads all three. Units: none.");
    prm.declare_entry("Export matrices", text(o.export_matrices), Patterns::Bool(),
                      "Write each space's K and M as <space>_K.csr / <space>_M.csr (binary CSR, see "
                      "benchmarks/eigensolver/README.md) for the eigensolver benchmark's peers. Units: none.");
    prm.leave_subsection();
  }

  void OutputParameters::parse_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Output");
    float64_modes   = prm.get("Mode precision") == "float64";
    vtu_modes       = prm.get_integer("VTU modes");
    const std::string compression = prm.get("VTU compression");
    vtu_compression = VtuCompression(std::find(std::begin(vtu_compression_names), std::end(vtu_compression_names),
                                               compression) - std::begin(vtu_compression_names));
    export_matrices = prm.get_bool("Export matrices");
    prm.leave_subsection();
  }

  // ---- Design variants -----------------------------------------------------------------------------
  namespace
  {
    const std::string name_characters = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-";

    std::string trimmed(const std::string &text)
    {
      const auto first = text.find_first_not_of(" \t\n");
      return first == std::string::npos ? "" : text.substr(first, text.find_last_not_of(" \t\n") - first + 1);
    }

    // "Geometry/Ribbed panel/Rib thicknesses = 1.5, 2, 2.4" -> its entry and its value.
    VariantOverride parse_override(const std::string &text, const std::string &where)
    {
      const auto equals = text.find('=');
      AssertThrow(equals != std::string::npos && !trimmed(text.substr(0, equals)).empty(),
                  ExcMessage(where + " = '" + text + "': expected 'SUBSECTION/ENTRY = VALUE', e.g. "
                             "'Material/Young's modulus = 3e9'."));
      return {trimmed(text.substr(0, equals)), trimmed(text.substr(equals + 1))};
    }
  } // namespace

  void VariantParameters::declare_parameters(ParameterHandler &prm)
  {
    const VariantParameters v;
    prm.enter_subsection("Variants");
    prm.declare_entry("Noise floor", text(v.noise_floor), Patterns::Bool(),
                      "Measure the re-meshing noise of the comparison: the base design meshed again with every "
                      "mesh size times 'Noise floor mesh scale' (another mesh of the same design), its "
                      "felt-stiffness map compared with the base's by the same rule; a variant's difference "
                      "below that noise is 'none' (per region: the global one, each VOI). It costs one more "
                      "precompute of the base design (43.5 s on the default scene on 2 cores). Units: none.");
    prm.declare_entry("Noise floor mesh scale", text(v.noise_floor_mesh_scale), OpenInterval(0.5, 2.),
                      "The factor on 'Meshing/Coarse size' and every VOI's 'Fine size' of the noise floor's run: "
                      "a few percent give gmsh another mesh while the discretisation error stays that of the "
                      "base's sizes. Not 1. Units: none.");
    for (unsigned int n = 1; n <= max_variants; ++n)
      {
        prm.enter_subsection("Variant " + std::to_string(n));
        prm.declare_entry("Name", "", Patterns::Anything(),
                          "Name of this design variant: its basis goes to <output folder>/variants/<name>/. "
                          "Letters, digits, '_' and '-'; empty: unused. Units: none.");
        for (unsigned int k = 1; k <= max_variant_overrides; ++k)
          prm.declare_entry("Override " + std::to_string(k), "", Patterns::Anything(),
                            "An entry of 'Geometry' (the part, its built-in panel's dimensions, its file, its "
                            "supports) or 'Material' that this variant sets otherwise than the scene: "
                            "'SUBSECTION/ENTRY = VALUE', e.g. 'Geometry/Ribbed panel/Rib thicknesses = 1.5, 2, "
                            "2.4'. Empty: unused. Units: none (the value is in the entry's own unit).");
        prm.leave_subsection();
      }
    prm.leave_subsection();
  }

  void VariantParameters::parse_parameters(ParameterHandler &prm, const std::string &parameter_file)
  {
    prm.enter_subsection("Variants");
    noise_floor            = prm.get_bool("Noise floor");
    noise_floor_mesh_scale = prm.get_double("Noise floor mesh scale");
    AssertThrow(noise_floor_mesh_scale != 1.,
                ExcMessage(parameter_file + ": 'Variants/Noise floor mesh scale' = 1 would mesh the base again "
                           "as it is: give a factor a few percent off 1, e.g. 1.03."));
    std::set<std::string> names;
    for (unsigned int n = 1; n <= max_variants; ++n)
      {
        DesignVariant variant;
        variant.section = "Variants/Variant " + std::to_string(n);
        prm.enter_subsection("Variant " + std::to_string(n));
        variant.name = prm.get("Name");
        for (unsigned int k = 1; k <= max_variant_overrides; ++k)
          if (const std::string o = prm.get("Override " + std::to_string(k)); !trimmed(o).empty())
            variant.overrides.push_back(
              parse_override(o, parameter_file + ": '" + variant.section + "/Override " + std::to_string(k) + "'"));
        prm.leave_subsection();
        if (variant.name.empty())
          continue;
        AssertThrow(variant.name.find_first_not_of(name_characters) == std::string::npos &&
                      variant.name != "noise_floor" && names.insert(variant.name).second,
                    ExcMessage(parameter_file + ": '" + variant.section + "/Name' = '" + variant.name +
                               "': use letters, digits, '_' and '-' only, a name no other variant has, and not "
                               "'noise_floor' (the noise floor's folder)."));
        AssertThrow(!variant.overrides.empty(),
                    ExcMessage(parameter_file + ": variant '" + variant.name + "' ('" + variant.section +
                               "') sets nothing otherwise than the scene: give it an 'Override 1'."));
        variants.push_back(std::move(variant));
      }
    prm.leave_subsection();
  }

  // ---- The scene: its name, then every subsection, then the checks across them ---------------------
  void declare_scene_parameters(ParameterHandler &prm)
  {
    prm.enter_subsection("Scene");
    prm.declare_entry("Name", SceneParameters().scene_name, Patterns::Anything(),
                      "Name of the scene: results go to results/<name>/ and files are named after it. "
                      "Letters, digits, '_' and '-' only. Units: none.");
    prm.leave_subsection();
    declare_geometry(prm);
    declare_meshing(prm);
    declare_scenarios(prm);
    MaterialParameters::declare_parameters(prm);
    ModeParameters::declare_parameters(prm);
    DampingParameters::declare_parameters(prm);
    ContactParameters::declare_parameters(prm);
    OutputParameters::declare_parameters(prm);
    VariantParameters::declare_parameters(prm);
  }

  namespace
  {
    // Checks that need two subsections.
    void check_across_subsections(const SceneParameters &scene)
    {
      AssertThrow(!scene.free_floating() || scene.modes.shift < 0.,
                  ExcMessage("The part is free-floating (no 'Geometry/Supports' and no 'Clamp groups'), so K is singular: set "
                             "'Modes/Shift' below zero (e.g. -0.1 times the first elastic frequency), not " +
                             text(scene.modes.shift) + " Hz."));
      AssertThrow(!scene.free_floating() || scene.modes.maximum_count > 6,
                  ExcMessage("The part is free-floating: its six lowest modes are rigid-body motions, so "
                             "'Modes/Maximum number of modes' = " + std::to_string(scene.modes.maximum_count) +
                             " leaves no elastic mode; ask for at least 7."));
      const std::string &geometry = scene.meshing.geometry;
      AssertThrow(!(geometry.size() > 4 && geometry.substr(geometry.size() - 4) == ".msh" &&
                    !scene.volumes_of_interest.empty()),
                  ExcMessage("Geometry '" + geometry + "' is a .msh file, which cannot be re-graded "
                             "around a VOI: give the geometry as STEP/.geo, or remove the 'Scenario' subsections."));
    }

    // Linear tets lock as nu -> 0.5 (the divergence-free constraint leaves them almost no motion):
    // frequencies and stiffness come out too high. Not an error, the user may want to see it, but a
    // warning (tests/precompute/test_nearly_incompressible.py measures the error).
    void warn_about_locking(const SceneParameters &scene)
    {
      if (scene.element_degree == 1 && scene.material.poissons_ratio >= 0.45)
        std::cerr << "Warning: 'Material/Poisson's ratio' = " << scene.material.poissons_ratio
                  << " with 'Meshing/Element degree' = 1: linear tets lock on nearly incompressible materials "
                     "(too stiff, frequencies too high); use Element degree = 2." << std::endl;
    }
  } // namespace

  SceneParameters parse_scene_parameters(ParameterHandler &prm,
                                         const std::string &parameter_file,
                                         const std::string &output_directory_override)
  {
    SceneParameters scene;
    scene.parameter_file = parameter_file;
    prm.enter_subsection("Scene");
    scene.scene_name = prm.get("Name");
    prm.leave_subsection();
    AssertThrow(!scene.scene_name.empty() &&
                  scene.scene_name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") ==
                    std::string::npos,
                ExcMessage("'Scene/Name' = '" + scene.scene_name + "': use letters, digits, '_' and '-' only."));
    scene.output_directory =
      output_directory_override.empty() ? "results/" + scene.scene_name : output_directory_override;

    parse_geometry(prm, scene);
    parse_meshing(prm, scene);
    parse_scenarios(prm, scene);
    scene.material.parse_parameters(prm);
    scene.modes.parse_parameters(prm);
    scene.damping.parse_parameters(prm);
    scene.contact.parse_parameters(prm);
    scene.output.parse_parameters(prm);
    check_across_subsections(scene);
    warn_about_locking(scene);
    return scene;
  }

  SceneParameters read_scene_parameters(ParameterHandler &prm,
                                        const std::string &parameter_file,
                                        const std::string &output_directory_override)
  {
    AssertThrow(std::filesystem::exists(parameter_file),
                ExcMessage("Parameter file '" + parameter_file + "' does not exist."));
    declare_scene_parameters(prm);
    parameter_messages::parse_input(prm, parameter_file);
    return parse_scene_parameters(prm, parameter_file, output_directory_override);
  }

  namespace
  {
    // A variant is another design of the part: what it may set otherwise.
    bool is_design_entry(const std::string &entry)
    {
      return entry.rfind("Geometry/", 0) == 0 || entry.rfind("Material/", 0) == 0;
    }

    // The variant's own scene holds no variant: its folder is one design.
    void clear_variants(ParameterHandler &prm)
    {
      prm.enter_subsection("Variants");
      prm.set("Noise floor", "false");
      for (unsigned int n = 1; n <= max_variants; ++n)
        {
          prm.enter_subsection("Variant " + std::to_string(n));
          prm.set("Name", "");
          for (unsigned int k = 1; k <= max_variant_overrides; ++k)
            prm.set("Override " + std::to_string(k), "");
          prm.leave_subsection();
        }
      prm.leave_subsection();
    }

    std::string listed(const std::vector<VariantOverride> &overrides)
    {
      std::string out;
      for (const auto &o : overrides)
        out += (out.empty() ? "'" : "; '") + o.entry + " = " + o.value + "'";
      return out;
    }
  } // namespace

  VariantScene read_variant_scene(const SceneParameters &base, const std::string &name,
                                  const std::vector<VariantOverride> &overrides, const std::string &output_directory,
                                  const bool design_only)
  {
    const std::string where = base.parameter_file + ", variant '" + name + "'";
    VariantScene      variant{name, overrides, nullptr, std::make_unique<ParameterHandler>()};
    ParameterHandler &prm = *variant.prm;
    declare_scene_parameters(prm);
    parameter_messages::parse_input(prm, base.parameter_file);
    clear_variants(prm);
    for (const auto &o : overrides)
      {
        AssertThrow(!design_only || is_design_entry(o.entry),
                    ExcMessage(where + ": the override '" + o.entry + " = " + o.value + "' is refused: a variant is "
                               "another design of the part, so it sets entries of 'Geometry' or 'Material' only (a "
                               "mesh size or a solver setting changes the discretisation, not the design)."));
        parameter_messages::set_entry(prm, o.entry, o.value, where);
      }
    try
      {
        variant.scene = std::make_unique<SceneParameters>(parse_scene_parameters(prm, base.parameter_file, output_directory));
      }
    catch (const dealii::ExceptionBase &e)
      {
        std::ostringstream message; // deal.II indents it
        e.print_info(message);
        throw ExcMessage(where + " (" + listed(overrides) + "): " + trimmed(message.str()));
      }
    return variant;
  }

  std::vector<VariantOverride> noise_floor_overrides(const ParameterHandler &prm, const SceneParameters &base,
                                                     const double scale)
  {
    std::vector<VariantOverride> overrides{{"Meshing/Coarse size", text(base.meshing.coarse_size * scale)}};
    for (unsigned int s = 1; s <= max_scenarios; ++s)
      {
        const std::string section = "Scenario " + std::to_string(s);
        const std::string name    = prm.get({section}, "Name");
        for (const auto &voi : base.volumes_of_interest)
          if (!name.empty() && voi.name == name) // its size as parsed: a default may have followed the coarse size
            overrides.push_back({section + "/Fine size", text(voi.fine_size * scale)});
      }
    return overrides;
  }

  void print_used_parameters(const ParameterHandler &prm, std::ostream &out)
  {
    std::ostringstream all;
    prm.print_parameters(all, ParameterHandler::Text);
    bool declares_variants = prm.get_bool({"Variants"}, "Noise floor");
    for (unsigned int n = 1; n <= max_variants; ++n)
      declares_variants |= !prm.get({"Variants", "Variant " + std::to_string(n)}, "Name").empty();
    if (declares_variants)
      {
        out << all.str();
        return;
      }
    // Text style writes a top-level subsection from 'subsection NAME' to 'end', both unindented,
    // and empty lines after it.
    std::istringstream lines(all.str());
    bool               in_variants = false, after_variants = false;
    for (std::string line; std::getline(lines, line);)
      {
        after_variants     = (after_variants && line.empty()) || (in_variants && line == "end");
        const bool skipped = in_variants || line == "subsection Variants" || after_variants;
        in_variants        = (in_variants || line == "subsection Variants") && line != "end";
        if (!skipped)
          out << line << '\n';
      }
  }
} // namespace modal_haptics
