// The scene's .prm file: every parameter the precompute reads, with its default, range and unit.
//
// Each struct declares and parses its own subsection (ASPECT's declare_parameters/parse_parameters):
// declare_parameters() documents each entry where it is declared (units in every description, the
// range in its Pattern) and takes the default from the struct's member initializer, so each default
// is written once; parse_parameters() reads the subsection back and cross-checks what a Pattern cannot
// say, throwing ExcMessage with the parameter and its value named for user errors. The meshing
// stage's structs (meshing/scene_mesher.h, free of deal.II) are declared and parsed in
// scene_parameters.cc beside the scene's.
#pragma once

#include <mrt/device_defaults.h>

#include <deal.II/base/parameter_handler.h>

#include "scene_mesher.h"
#include "scene/supports.h"

#include <optional>
#include <string>
#include <vector>

namespace modal_haptics
{
  struct MaterialParameters
  {
    double youngs_modulus = 2.3e9; // [Pa]
    double poissons_ratio = 0.35;  // [-]
    double density        = 1050.; // [kg/m^3]

    static void declare_parameters(dealii::ParameterHandler &prm); // subsection "Material"
    void        parse_parameters(dealii::ParameterHandler &prm);
  };

  enum class CutOffRule
  {
    none,    // keep the maximum count
    display, // original method: drop modes above half the display frame rate
    haptic   // drop modes above half the haptic rate (the Nyquist frequency of the haptic loop)
  };

  enum class FactorizationKind
  {
    cholmod, // supernodal Cholesky with METIS ordering (SuiteSparse): the default
    umfpack  // deal.II's SparseDirectUMFPACK LU: slow, kept as a peer
  };

  enum class DistributedFactorizationKind
  {
    mumps_cholesky, // MUMPS in its symmetric mode (L D L^T), through its C interface: the default
    mumps_lu        // Trilinos Amesos_Mumps: MUMPS's unsymmetric LU, kept as a peer
  };

  // Where MUMPS's factor lives (under mpirun, --distributed, or a serial run's space handed to MUMPS;
  // CHOLMOD's factor is always in memory).
  enum class FactorStorage
  {
    automatic, // in memory when MUMPS's analysis says it fits 'Factor memory limit', else on disk; a
               // serial run hands a space to MUMPS when CHOLMOD's factor would not fit
    memory,    // in core
    disk       // out of core: MUMPS writes the factor to files and reads it back at every solve
  };

  enum class EigensolverKind
  {
    automatic,    // block_krylov over whichever factor fits (CHOLMOD's, MUMPS's in memory or on disk), else lobpcg_amg
    block_krylov, // block Krylov on the shift-invert operator (blocks of solves with the factorization)
    arpack,       // ARPACK's dsaupd on the shift-invert operator, one vector per solve
    lobpcg_amg    // LOBPCG preconditioned by AMG: no factorization (amg_eigensolver.h)
  };

  std::string     eigensolver_name(EigensolverKind kind); // as 'Modes/Eigensolver' spells it
  EigensolverKind eigensolver_kind(const std::string &name);

  struct ModeParameters
  {
    unsigned int maximum_count = 50;
    unsigned int minimum_count = 10;
    CutOffRule   cut_off_rule  = CutOffRule::haptic;
    double       display_rate  = 60.;   // [Hz]
    double       haptic_rate   = 1000.; // [Hz]
    double       shift         = 0.;    // shift-invert shift [Hz]
    double       tolerance     = 1e-10; // ARPACK relative tolerance on Ritz values
    FactorizationKind factorization_kind = FactorizationKind::cholmod;
    DistributedFactorizationKind distributed_factorization = DistributedFactorizationKind::mumps_cholesky;
    EigensolverKind eigensolver = EigensolverKind::automatic;
    double       lobpcg_tolerance = 1e-6; // lobpcg-amg: relative residual of every wanted pair
    unsigned int lobpcg_modes_per_run = 0; // lobpcg-amg: the most modes one LOBPCG run seeks; 0: automatic
    double       factor_memory_limit = 0.; // auto: the largest direct factor [GB]; 0: half the available memory
    unsigned int block_size    = 4;     // right-hand sides per block solve of the block Krylov method
    FactorStorage factor_storage = FactorStorage::automatic;
    std::string   factor_directory; // MUMPS's out-of-core files; empty: $MUMPS_OOC_TMPDIR, $TMPDIR or /tmp

    // The cut-off frequency [Hz] the rule gives, +inf for CutOffRule::none.
    double cut_off_frequency() const;

    static void declare_parameters(dealii::ParameterHandler &prm); // subsection "Modes"
    void        parse_parameters(dealii::ParameterHandler &prm);
  };

  struct DampingParameters
  {
    bool   rayleigh      = true;
    double alpha         = 0.;    // mass-proportional coefficient [1/s]
    double beta          = 2e-5;  // stiffness-proportional coefficient [s]
    double modal_ratio   = 0.02;  // constant modal damping ratio when rayleigh = false [-]

    // Damping ratio of a mode of angular frequency omega [rad/s].
    double ratio(double omega) const;

    static void declare_parameters(dealii::ParameterHandler &prm); // subsection "Damping"
    void        parse_parameters(dealii::ParameterHandler &prm);
  };

  struct ContactParameters
  {
    double       patch_radius          = 2.;  // [geometry units]
    unsigned int global_candidate_stride = 1; // every n-th display vertex of the global region; 0 = none
    // The global space also corrects every display vertex inside a VOI: it is the space two HIPs in
    // two regions switch to (realtime/src/space_switch.cc), and there a contact must not fall to the modes.
    bool         global_candidates_in_vois = true;
    unsigned int maximum_candidates    = 1000000; // per space, thinned evenly above this
    bool         cross_compliance      = true;
    double       cross_compliance_radius = 0.; // pairs closer than this (0: sharing a display triangle) [geometry units]
    unsigned int validation_pairs      = 2;   // pairs of neighbouring candidates pressed together and validated
    unsigned int far_field_rank        = 64;  // rank of the residual coupling of candidates farther apart; 0 = none
    unsigned int validation_samples    = 4;   // sampled candidates per space
    double       correction_field_tolerance = 1e-3; // relative truncation of the display correction field
    // Anticipated contact points [geometry units]: the nearest display vertex becomes a candidate of
    // the space whose VOI holds it and is validated in every space.
    std::vector<meshing::Point3> validation_points;
    // Anticipated multi-contact presses [geometry units]: two points each; in every space, the cross
    // blocks between every candidate within exact_pair_reach of one point (and the one nearest to
    // it, with its triangle neighbours) and every such candidate of the other are stored, so that
    // two hands there feel the full-FE answer however far apart.
    std::vector<std::array<meshing::Point3, 2>> exact_pairs;
    double       exact_pair_reach      = 0.;  // [geometry units]; 0: twice patch_radius (resolved when parsed)
    // Where linear stops being true (precompute/nonlinear/large_deformation.h): at each validation
    // point, a geometrically nonlinear solve of the patch load ramped up to force_limit.
    double       force_limit         = mrt::default_max_force; // [N] the kernel's default device.max_force
    bool         validity_analysis   = false; // off: a nonlinear full solve per point (its cost: docs/accuracy.md)
    bool         validity_neo_hookean = true; // else St. Venant-Kirchhoff
    std::optional<meshing::Point3> validity_direction; // unit; empty: the surface's inward normal
    unsigned int validity_load_steps = 5;    // first load increment = force_limit / this
    bool         validity_estimate   = true; // the second-order estimate at every corrected contact (the map)
    bool         validity_cg         = true; // Newton's tangent systems by CG preconditioned by K's factor

    static void declare_parameters(dealii::ParameterHandler &prm); // subsection "Contact"
    void        parse_parameters(dealii::ParameterHandler &prm);
  };

  // zlib on the VTU files' data arrays (deal.II's DataOut writes them base64 either way).
  enum class VtuCompression
  {
    none,
    fast,
    best
  };

  struct OutputParameters
  {
    bool           float64_modes   = false; // .mrt display modes in float64 instead of float32
    unsigned int   vtu_modes       = 10;    // number of mode shapes written to VTU
    VtuCompression vtu_compression = VtuCompression::none;
    bool         export_matrices = false; // write K and M (binary CSR) for the benchmark's peers

    static void declare_parameters(dealii::ParameterHandler &prm); // subsection "Output"
    void        parse_parameters(dealii::ParameterHandler &prm);
  };

  struct SceneParameters
  {
    std::string scene_name = "ribbed_panel";
    std::string parameter_file;   // the .prm that was read (for messages)
    std::string output_directory; // resolved: given, or results/<scene>

    meshing::MeshingSettings                meshing;
    std::vector<meshing::VolumeOfInterest>  volumes_of_interest;
    double       length_unit   = 1e-3; // metres per geometry unit
    std::vector<Support> supports = clamp_group_supports({"clamp"}); // empty: a free-floating part
    bool free_floating() const { return supports.empty(); }
    unsigned int element_degree = 2;

    MaterialParameters material;
    ModeParameters     modes;
    DampingParameters  damping;
    ContactParameters  contact;
    OutputParameters   output;
  };

  // Up to this many VOI subsections ("Scenario 1" ... ) may be used.
  constexpr unsigned int max_scenarios = 6;

  void declare_scene_parameters(dealii::ParameterHandler &prm);

  // Reads the entries (after prm.parse_input) and cross-checks them. The output directory is
  // results/<scene> unless output_directory_override is non-empty.
  SceneParameters parse_scene_parameters(dealii::ParameterHandler &prm,
                                         const std::string &parameter_file,
                                         const std::string &output_directory_override);

  // Parses a .prm file into a SceneParameters: declare, parse_input (unknown entries and bad patterns
  // throw with the file and line), then parse_scene_parameters.
  SceneParameters read_scene_parameters(dealii::ParameterHandler &prm,
                                        const std::string &parameter_file,
                                        const std::string &output_directory_override);
} // namespace modal_haptics
