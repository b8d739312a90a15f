// The choice of backend, method and factor placement (solver_choice.h). Read from the top: a serial
// run, then the distributed backend (under mpirun, --distributed, or a serial run's hand-over).
#include "solvers/solver_choice.h"

#include "parameters/scene_parameters.h"

#include <sstream>

namespace modal_haptics::solver_choice
{
  namespace
  {
    Choice decided(const Backend backend, const Factor factor, const Method method, const Placement placement,
                   const Needs needs = Needs::nothing)
    {
      Choice choice;
      choice.backend   = backend;
      choice.factor    = factor;
      choice.method    = method;
      choice.placement = placement;
      choice.needs     = needs;
      return choice;
    }

    Choice refused(const std::string &why)
    {
      Choice choice = decided(Backend::distributed, Factor::none, Method::block_krylov, Placement::none);
      choice.refusal = why;
      return choice;
    }

    bool automatic(const Settings &s) { return s.eigensolver == EigensolverKind::automatic; }

    // The method over a factor: the one named, block Krylov for 'auto'.
    Method over_a_factor(const Settings &s)
    {
      return s.eigensolver == EigensolverKind::arpack ? Method::arpack : Method::block_krylov;
    }

    Factor mumps_factor(const Settings &s)
    {
      return s.distributed_factorization == DistributedFactorizationKind::mumps_lu ? Factor::mumps_lu :
                                                                                       Factor::mumps_symmetric;
    }

    // Eigensolver = auto: why this path, for the report. Only what does not move with the machine's
    // free memory when the factor fits (scenario jobs compare their reports with a one-run report's).
    // on_disk: the factor was put on disk (MUMPS) to fit, predicted_bytes then its out-of-core data.
    std::string auto_note(const bool factorized, const double predicted_bytes, const double limit_bytes,
                          const bool on_disk)
    {
      std::ostringstream why;
      if (factorized && on_disk)
        why << " (auto: the factor on disk, its in-core data fits the limit)";
      else if (factorized)
        why << " (auto: the predicted factor fits the limit)";
      else
        why << " (auto: predicted " << (on_disk ? "in-core data with the factor on disk " : "factor ")
            << predicted_bytes / 1e9 << " GB over the limit " << limit_bytes / 1e9 << " GB)";
      return why.str();
    }

    // A serial run's space computed by MUMPS on this one process (the distributed backend on
    // MPI_COMM_SELF), which then chooses its method and placement itself.
    Choice hand_over_to_mumps(const Settings &s, const std::string &why)
    {
      Choice choice = decided(Backend::mumps_on_this_process, mumps_factor(s), over_a_factor(s), Placement::none);
      choice.log_line    = why + ": MUMPS computes the space on this process";
      choice.report_note = " [MUMPS on one process, for the serial run: " + why + "]";
      return choice;
    }

    // Past CHOLMOD's analysis: its factor in memory while it fits 'Modes/Factor memory limit'; past
    // it MUMPS takes the space over when it may; else 'auto' takes LOBPCG + AMG and a method named
    // factorizes all the same.
    Choice serial_with_cholmod_analysis(const Settings &s, const CholmodAnalysis &cholmod, const bool mumps_may_take_over)
    {
      const bool         fits = cholmod.factor_bytes <= cholmod.limit_bytes; // as make_cholmod_factorization_within
      std::ostringstream over;
      over << "CHOLMOD's analysis predicts a factor of " << cholmod.factor_bytes / 1e9
           << " GB, 'Modes/Factor memory limit' is " << cholmod.limit_bytes / 1e9 << " GB";
      if (!fits && mumps_may_take_over)
        return hand_over_to_mumps(s, "'Modes/Factor storage = auto': " + over.str());
      const std::string why_not_mumps =
        s.storage == FactorStorage::automatic ?
          "MUMPS's path, whose factor may go to disk, does not take parts with free rigid-body motions" :
          "'Factor storage = memory' keeps MUMPS's factor off disk";
      if (!automatic(s))
        {
          Choice choice = decided(Backend::serial, Factor::cholmod, over_a_factor(s), Placement::memory);
          if (!fits)
            choice.log_line = over.str() + ": factorizing all the same, as 'Modes/Eigensolver' names the method (" +
                              why_not_mumps + ")";
          return choice;
        }
      Choice choice = fits ? decided(Backend::serial, Factor::cholmod, Method::block_krylov, Placement::memory) :
                             decided(Backend::serial, Factor::none, Method::lobpcg_amg, Placement::none);
      choice.log_line    = "Modes/Eigensolver = auto: " + over.str() + ": " +
                        (fits ? "block-krylov" : "lobpcg-amg (no factorization; " + why_not_mumps + ")");
      choice.report_note = auto_note(fits, cholmod.factor_bytes, cholmod.limit_bytes, false);
      return choice;
    }

    // A serial run: CHOLMOD's factor (or UMFPACK's) in memory. A factor on disk is MUMPS's: 'Factor
    // storage = disk' hands the space to MUMPS before assembly, 'auto' when CHOLMOD's analysis
    // predicts a factor past the limit (not a part with free rigid-body motions, which MUMPS's path
    // does not take). UMFPACK predicts nothing: 'auto' then says nothing either.
    Choice serial(const Known &k)
    {
      const Settings &s = k.settings;
      if (s.eigensolver == EigensolverKind::lobpcg_amg)
        return decided(Backend::serial, Factor::none, Method::lobpcg_amg, Placement::none);
      if (s.storage == FactorStorage::disk)
        return hand_over_to_mumps(s, "'Modes/Factor storage = disk'");
      const Factor factor =
        s.factorization == FactorizationKind::cholmod ? Factor::cholmod : Factor::umfpack;
      if (!k.free_motions)
        return decided(Backend::serial, factor, over_a_factor(s), Placement::memory, Needs::supports);
      const bool mumps_may_take_over = s.storage == FactorStorage::automatic && !*k.free_motions;
      if (factor == Factor::umfpack || (!automatic(s) && !mumps_may_take_over))
        return decided(Backend::serial, factor, over_a_factor(s), Placement::memory);
      if (!k.cholmod)
        return decided(Backend::serial, factor, over_a_factor(s), Placement::memory, Needs::cholmod_analysis);
      return serial_with_cholmod_analysis(s, *k.cholmod, mumps_may_take_over);
    }

    // Past MUMPS's analysis: the factor in memory, or on disk ('Factor storage = disk', or 'auto'
    // when the in-core data would exceed the process's share of the limit); 'Eigensolver = auto'
    // takes LOBPCG + AMG when even the storage taken would exceed it. The LU always factorizes.
    Choice distributed_with_mumps_analysis(const Settings &s, const MumpsAnalysis &mumps)
    {
      const MumpsPrediction &p     = mumps.predicted;
      const double           limit = mumps.limit_bytes_per_process * mumps.processes_on_node; // the node's
      Choice choice = decided(Backend::distributed, mumps_factor(s), over_a_factor(s), Placement::memory);
      if (choice.factor == Factor::mumps_lu)
        {
          choice.log_line = "MUMPS's LU (Amesos) does not predict its memory: factorizing in memory";
          choice.report_note = automatic(s) ? auto_note(true, p.in_core_bytes * mumps.processes_on_node, limit, false) : "";
          return choice;
        }
      const bool on_disk = s.storage == FactorStorage::disk ||
                           (s.storage == FactorStorage::automatic && p.in_core_bytes > mumps.limit_bytes_per_process);
      const double need      = on_disk ? p.out_of_core_bytes : p.in_core_bytes;
      const bool   factorize = !automatic(s) || need <= mumps.limit_bytes_per_process;
      if (!factorize)
        choice = decided(Backend::distributed, Factor::none, Method::lobpcg_amg, Placement::none);
      else if (on_disk)
        choice.placement = Placement::disk;
      std::ostringstream line;
      line << "MUMPS's analysis predicts " << p.in_core_bytes / 1e9 << " GB in core, " << p.out_of_core_bytes / 1e9
           << " GB with the factor (" << p.factor_bytes / 1e9 << " GB) on disk, on the process that needs most; the "
           << "limit is " << mumps.limit_bytes_per_process / 1e9 << " GB per process (" << limit / 1e9 << " GB for the "
           << mumps.processes_on_node << " on its node): "
           << (!factorize ? "lobpcg-amg (no factorization)" :
               on_disk    ? "factorizing, the factor on disk" :
                            "factorizing, the factor in memory");
      choice.log_line = line.str();
      if (automatic(s))
        choice.report_note = auto_note(factorize, need * mumps.processes_on_node, limit, on_disk);
      return choice;
    }

    // The distributed backend: MUMPS factorizes (the serial 'Operator' does not apply), or LOBPCG +
    // AMG when named. It takes no part with free rigid-body motions, and MUMPS's LU through Amesos
    // keeps its factor in memory.
    Choice distributed(const Known &k)
    {
      const Settings &s = k.settings;
      if (!k.free_motions)
        return decided(Backend::distributed, mumps_factor(s), over_a_factor(s), Placement::memory, Needs::supports);
      if (*k.free_motions)
        return refused("such a part runs on the serial path's CHOLMOD only: MUMPS's path neither identifies the "
                       "rigid-body modes nor keeps its static answers free of them. Run modal-precompute without "
                       "mpirun or --distributed, and without 'Modes/Factor storage = disk'.");
      if (s.eigensolver == EigensolverKind::lobpcg_amg)
        return decided(Backend::distributed, Factor::none, Method::lobpcg_amg, Placement::none);
      if (mumps_factor(s) == Factor::mumps_lu && s.storage == FactorStorage::disk)
        return refused("'Modes/Factor storage = disk' needs 'Modes/Distributed factorization = mumps-cholesky': "
                       "MUMPS's LU through Trilinos Amesos keeps its factor in memory.");
      if (k.mumps)
        return distributed_with_mumps_analysis(s, *k.mumps);
      Choice choice =
        decided(Backend::distributed, mumps_factor(s), over_a_factor(s), Placement::memory, Needs::mumps_analysis);
      if (s.factorization != FactorizationKind::cholmod)
        choice.log_line = "Modes/Operator (umfpack) chooses the serial factorization; under MPI MUMPS factorizes K";
      return choice;
    }
  } // namespace

  Choice choose(const Known &known)
  {
    return known.distributed ? distributed(known) : serial(known);
  }
} // namespace modal_haptics::solver_choice
