// Which eigensolver computes a modal space, over which factorization, and where the factor lives,
// as one value: the backend (the serial one over CHOLMOD or UMFPACK; MUMPS on this one process for a
// serial run; the distributed one over MUMPS or Trilinos Amesos' LU), the method (block Krylov,
// ARPACK, LOBPCG + AMG), the factor's placement (memory, disk, none) and the words the log and the
// report say about it. Every rule is in choose() (solver_choice.cc, one page); the spaces carry out
// what it returns, and ask again where an analysis has predicted what the factor needs. No deal.II:
// tests/precompute/test_solver_choice.cc checks the whole decision table without assembling anything.
#pragma once

#include <optional>
#include <string>

namespace modal_haptics
{
  // The 'Modes' settings, defined with their words in parameters/scene_parameters.h.
  enum class EigensolverKind;
  enum class FactorStorage;
  enum class FactorizationKind;
  enum class DistributedFactorizationKind;

  namespace solver_choice
  {
    // What the parameters ask for.
    struct Settings
    {
      EigensolverKind              eigensolver;               // 'Modes/Eigensolver'
      FactorStorage                storage;                   // 'Modes/Factor storage'
      FactorizationKind            factorization;             // 'Modes/Operator' (the serial backend's)
      DistributedFactorizationKind distributed_factorization; // 'Modes/Distributed factorization'
    };

    // CHOLMOD's analysis: the factor it predicts, and 'Modes/Factor memory limit' when it predicted.
    struct CholmodAnalysis
    {
      double factor_bytes;
      double limit_bytes;
    };

    // What MUMPS's analysis predicts on the process that needs most: its in-core data with the factor in
    // memory (INFOG(16)) and with the factor on disk (INFOG(26)), and the factor's values on all
    // processes (INFOG(3)); -1 where MUMPS's LU through Amesos cannot tell before it factorizes.
    struct MumpsPrediction
    {
      double in_core_bytes     = -1.;
      double out_of_core_bytes = -1.;
      double factor_bytes      = -1.;
    };
    struct MumpsAnalysis
    {
      MumpsPrediction predicted;
      double          limit_bytes_per_process; // each process's share of its node's limit
      unsigned int    processes_on_node;
    };

    // What is known at a decision point: the settings before assembly, the supports' free motions
    // after it, an analysis's prediction once it has run.
    struct Known
    {
      Settings                       settings;
      bool                           distributed = false; // mpirun, --distributed, or a serial run's hand-over
      std::optional<bool>            free_motions;        // the supports leave rigid-body motions free
      std::optional<CholmodAnalysis> cholmod;
      std::optional<MumpsAnalysis>   mumps;
    };

    enum class Backend
    {
      serial,                // CHOLMOD or UMFPACK, or LOBPCG + AMG, on deal.II matrices
      mumps_on_this_process, // a serial run hands the space to the distributed backend on MPI_COMM_SELF
      distributed            // Trilinos matrices, MUMPS or Amesos' LU, or LOBPCG + AMG
    };
    enum class Factor
    {
      none,            // LOBPCG + AMG
      cholmod,
      umfpack,
      mumps_symmetric, // MUMPS's L D L^T through its C interface
      mumps_lu         // MUMPS's LU through Trilinos Amesos
    };
    enum class Method
    {
      block_krylov,
      arpack, // PARPACK on the distributed backend
      lobpcg_amg
    };
    enum class Placement
    {
      none,
      memory,
      disk
    };
    // What a choice waits for before it is final; until then its other fields are what it would be
    // without the missing knowledge.
    enum class Needs
    {
      nothing,
      supports,         // whether they leave free motions (after assembly)
      cholmod_analysis, // CHOLMOD's, against the limit: the serial space then asks again
      mumps_analysis    // MUMPS's (the LU's predicts nothing): make_mumps_inverse asks again
    };

    struct Choice
    {
      Backend     backend   = Backend::serial;
      Factor      factor    = Factor::none;
      Method      method    = Method::block_krylov;
      Placement   placement = Placement::none;
      Needs       needs     = Needs::nothing;
      std::string refusal;     // non-empty: no backend takes the space with these settings, and why
      std::string log_line;    // the choice as the log says it, or empty
      std::string report_note; // appended to the report's eigensolver method: why 'auto' chose, a hand-over
    };

    // The choice from what is known: call it at each decision point with what is known then.
    // Backend::mumps_on_this_process ends a serial space's choice: the distributed backend then
    // chooses for itself on one process (Known::distributed).
    Choice choose(const Known &known);
  } // namespace solver_choice
} // namespace modal_haptics
