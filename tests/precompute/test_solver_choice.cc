// The solver choice (precompute/solvers/solver_choice.h) against its decision table, without
// assembling anything: every combination of 'Modes/Eigensolver' x 'Factor storage' x 'Operator' x
// 'Distributed factorization' x free rigid-body motions or not x a serial or a distributed run x
// CHOLMOD's predicted factor within the limit or not x MUMPS's predicted in-core data within its share
// or not x its out-of-core data within it or not (1536 cases). Each case is carried out as the spaces
// do it: choose() before assembly, again with the supports' free motions, again with each analysis's
// prediction, and a serial run's hand-over to MUMPS chosen anew by the distributed backend on one
// process. Checked: the backend, factor, method and placement the table below gives; the report's
// note says why wherever 'Eigensolver = auto' chose from a prediction (never where a method was
// named), and a hand-over says so; some notes word for word (the tests and docs/report-schema.md
// read them); a serial run's 'Factor storage = disk' hands over before assembly; no choice waits
// twice for the same thing.
#include "parameters/scene_parameters.h"
#include "solvers/solver_choice.h"

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

namespace
{
  using namespace modal_haptics;
  using namespace modal_haptics::solver_choice;

  int failures = 0;
  int checks   = 0;

  void check(const bool ok, const std::string &what)
  {
    ++checks;
    if (!ok && failures++ < 40)
      std::printf("FAILED: %s\n", what.c_str());
  }

  // The decision table, as read from the code before the choice became one function (the serial
  // space's factorize_unless_amg and factorize_within_limit, compute_modal_space's hand-over, the
  // distributed space's factorize_unless_amg and setup_system, make_mumps_inverse). First matching
  // row wins; '*' matches anything.
  //   inputs:  run (serial|mpi), Eigensolver (auto|krylov|arpack|lobpcg), Factor storage
  //            (auto|memory|disk), Operator (cholmod|umfpack), Distributed factorization (sym|lu),
  //            supports (free|fixed), CHOLMOD's factor, MUMPS's in-core data, its out-of-core data
  //            (fits|over the limit)
  //   outputs: backend (serial|self = MUMPS on this process for a serial run|mpi|refused), factor
  //            (none|cholmod|umfpack|mumps|lu), method (krylov|arpack|lobpcg|asked = arpack if named,
  //            else krylov), placement (none|memory|disk), the '(auto: ...)' note (yes|no|ifauto =
  //            yes with Eigensolver = auto)
  const char *const table[][2] = {
    // run    eigen   storage operator dist free  chol  core  ooc      backend factor  method placement note
    {"serial lobpcg  *      *        *    *     *     *     *",    "serial none    lobpcg none   no"},
    // 'Factor storage = disk': MUMPS on this process, chosen before assembly; it then chooses as mpi.
    {"serial *       disk   *        *    free  *     *     *",    "refused"},
    {"serial *       disk   *        lu   *     *     *     *",    "refused"},
    {"serial auto    disk   *        sym  *     *     *     fits", "self   mumps   krylov disk   yes"},
    {"serial auto    disk   *        sym  *     *     *     over", "self   none    lobpcg none   yes"},
    {"serial *       disk   *        sym  *     *     *     *",    "self   mumps   asked  disk   no"},
    // UMFPACK predicts nothing: no limit, no hand-over, and 'auto' says nothing.
    {"serial *       *      umfpack  *    *     *     *     *",    "serial umfpack asked  memory no"},
    {"serial *       *      cholmod  *    *     fits  *     *",    "serial cholmod asked  memory ifauto"},
    // CHOLMOD's factor over the limit, 'Factor storage = auto', no free motion: MUMPS on this process.
    {"serial *       auto   cholmod  lu   fixed over  *     *",    "self   lu      asked  memory ifauto"},
    {"serial *       auto   cholmod  sym  fixed over  fits  *",    "self   mumps   asked  memory ifauto"},
    {"serial auto    auto   cholmod  sym  fixed over  over  over", "self   none    lobpcg none   yes"},
    {"serial *       auto   cholmod  sym  fixed over  over  *",    "self   mumps   asked  disk   ifauto"},
    // Over the limit where MUMPS may not take the space ('memory', free motions).
    {"serial auto    *      cholmod  *    *     over  *     *",    "serial none    lobpcg none   yes"},
    {"serial *       *      cholmod  *    *     over  *     *",    "serial cholmod asked  memory no"},
    // The distributed backend (mpirun, --distributed).
    {"mpi    *       *      *        *    free  *     *     *",    "refused"},
    {"mpi    lobpcg  *      *        *    *     *     *     *",    "mpi    none    lobpcg none   no"},
    {"mpi    *       disk   *        lu   *     *     *     *",    "refused"},
    {"mpi    *       *      *        lu   *     *     *     *",    "mpi    lu      asked  memory ifauto"},
    {"mpi    *       memory *        sym  *     *     fits  *",    "mpi    mumps   asked  memory ifauto"},
    {"mpi    auto    memory *        sym  *     *     over  *",    "mpi    none    lobpcg none   yes"},
    {"mpi    *       memory *        sym  *     *     over  *",    "mpi    mumps   asked  memory no"},
    {"mpi    *       auto   *        sym  *     *     fits  *",    "mpi    mumps   asked  memory ifauto"},
    {"mpi    auto    *      *        sym  *     *     *     over", "mpi    none    lobpcg none   yes"},
    {"mpi    *       *      *        sym  *     *     *     *",    "mpi    mumps   asked  disk   ifauto"},
  };

  std::vector<std::string> words(const std::string &text)
  {
    std::istringstream       in(text);
    std::vector<std::string> w;
    for (std::string word; in >> word;)
      w.push_back(word);
    return w;
  }

  struct Case
  {
    bool                         distributed;
    EigensolverKind              eigensolver;
    FactorStorage                storage;
    FactorizationKind            factorization;
    DistributedFactorizationKind distributed_factorization;
    bool                         free, cholmod_fits, in_core_fits, out_of_core_fits;

    std::vector<std::string> tokens() const
    {
      const char *eigen[] = {"auto", "krylov", "arpack", "lobpcg"};
      const char *store[] = {"auto", "memory", "disk"};
      const auto  fits    = [](const bool f) { return f ? "fits" : "over"; };
      return {distributed ? "mpi" : "serial",
              eigen[int(eigensolver)],
              store[int(storage)],
              factorization == FactorizationKind::cholmod ? "cholmod" : "umfpack",
              distributed_factorization == DistributedFactorizationKind::mumps_lu ? "lu" : "sym",
              free ? "free" : "fixed",
              fits(cholmod_fits),
              fits(in_core_fits),
              fits(out_of_core_fits)};
    }
    std::string name() const
    {
      std::string n;
      for (const auto &t : tokens())
        n += t + " ";
      return n;
    }
  };

  std::vector<std::string> expected(const Case &c)
  {
    const auto inputs = c.tokens();
    for (const auto &row : table)
      {
        const auto pattern = words(row[0]);
        bool       match   = true;
        for (std::size_t i = 0; i < pattern.size(); ++i)
          match = match && (pattern[i] == "*" || pattern[i] == inputs[i]);
        if (match)
          return words(row[1]);
      }
    return {"no row"};
  }

  // The final choice of a case, carried out as the spaces do.
  struct Outcome
  {
    Choice                   choice;
    std::string              note;            // the report's: the auto note, then a hand-over's
    std::vector<std::string> log;             // every log line the choices gave
    int                      hand_over_call = -1; // the serial run's call that handed over
    std::string              problem;         // a choice that asked for what it had or cannot get
  };

  // limit: CHOLMOD's 1 GB; MUMPS's share 1 GB per process, two processes on a node under mpirun.
  Outcome carry_out(const Case &c, Known known)
  {
    Outcome out;
    for (int call = 0; call < 6; ++call)
      {
        const Choice choice = choose(known);
        if (!choice.log_line.empty())
          out.log.push_back(choice.log_line);
        if (choice.backend == Backend::mumps_on_this_process && choice.refusal.empty())
          {
            if (known.distributed)
              out.problem = "the distributed backend handed over";
            Outcome mumps       = carry_out(c, Known{known.settings, /*distributed*/ true, {}, {}, {}});
            mumps.note         += choice.report_note;
            mumps.hand_over_call = call;
            mumps.log.insert(mumps.log.begin(), out.log.begin(), out.log.end());
            mumps.problem += out.problem;
            return mumps;
          }
        if (!choice.refusal.empty() || choice.needs == Needs::nothing)
          {
            out.choice = choice;
            out.note += choice.report_note;
            return out;
          }
        const bool         lu       = c.distributed_factorization == DistributedFactorizationKind::mumps_lu;
        const unsigned int on_node  = c.distributed ? 2 : 1;
        if (choice.needs == Needs::supports && !known.free_motions)
          known.free_motions = c.free;
        else if (choice.needs == Needs::cholmod_analysis && !known.cholmod && !known.distributed)
          known.cholmod = CholmodAnalysis{c.cholmod_fits ? 0.5e9 : 2e9, 1e9};
        else if (choice.needs == Needs::mumps_analysis && !known.mumps && known.distributed)
          known.mumps = MumpsAnalysis{lu ? MumpsPrediction{} :
                                           MumpsPrediction{c.in_core_fits ? 0.8e9 : 1.2e9,
                                                           c.out_of_core_fits ? 0.3e9 : 1.1e9, 3e9},
                                      1e9, on_node};
        else
          {
            out.problem = "a choice waits for what it has or cannot get (call " + std::to_string(call) + ")";
            return out;
          }
      }
    out.problem = "no final choice after 6 calls";
    return out;
  }

  void check_case(const Case &c)
  {
    const std::string name = c.name();
    const Settings    settings{c.eigensolver, c.storage, c.factorization, c.distributed_factorization};
    const Outcome     out  = carry_out(c, Known{settings, c.distributed, {}, {}, {}});
    const auto        want = expected(c);
    check(out.problem.empty(), name + ": " + out.problem);
    check(want[0] != "no row", name + ": no row of the table");
    if (want[0] == "refused" || !out.choice.refusal.empty())
      {
        check(want[0] == "refused" && !out.choice.refusal.empty(), name + ": refused, as the table says");
        return;
      }
    const bool        automatic = c.eigensolver == EigensolverKind::automatic;
    const char       *factors[] = {"none", "cholmod", "umfpack", "mumps", "lu"};
    const char       *methods[] = {"krylov", "arpack", "lobpcg"};
    const char       *places[]  = {"none", "memory", "disk"};
    const std::string method    = want[2] != "asked" ? want[2] :
                                  c.eigensolver == EigensolverKind::arpack ? "arpack" : "krylov";
    const std::string backend   = out.hand_over_call >= 0 ? "self" : c.distributed ? "mpi" : "serial";
    check(backend == want[0], name + ": backend " + backend + ", the table says " + want[0]);
    check(out.choice.backend == (c.distributed || out.hand_over_call >= 0 ? Backend::distributed : Backend::serial),
          name + ": the final choice's backend is the one that computes");
    check(factors[int(out.choice.factor)] == want[1], name + ": factor " + factors[int(out.choice.factor)] + " vs " + want[1]);
    check(methods[int(out.choice.method)] == method, name + ": method " + methods[int(out.choice.method)] + " vs " + method);
    check(places[int(out.choice.placement)] == want[3], name + ": placement " + places[int(out.choice.placement)] + " vs " + want[3]);
    const bool auto_note = want[4] == "yes" || (want[4] == "ifauto" && automatic);
    check((out.note.find(" (auto: ") != std::string::npos) == auto_note,
          name + ": the report's note '" + out.note + "' " + (auto_note ? "says why auto chose" : "has no auto note"));
    check(!auto_note || !out.log.empty(), name + ": the log says what auto chose");
    const bool handed_over = out.note.find(" [MUMPS on one process, for the serial run: ") != std::string::npos;
    check(handed_over == (backend == "self"), name + ": the note names the hand-over");
    check(backend != "self" || c.storage != FactorStorage::disk || out.hand_over_call == 0,
          name + ": 'Factor storage = disk' hands over before assembly");
    check(backend != "self" || c.storage == FactorStorage::disk ||
            out.note.find("CHOLMOD's analysis predicts a factor of 2 GB, 'Modes/Factor memory limit' is 1 GB") !=
              std::string::npos,
          name + ": the hand-over says what CHOLMOD predicted");
  }

  // Words other tests and docs/report-schema.md read, word for word.
  void check_words()
  {
    const auto note = [](const Case &c) {
      const Settings s{c.eigensolver, c.storage, c.factorization, c.distributed_factorization};
      return carry_out(c, Known{s, c.distributed, {}, {}, {}}).note;
    };
    using E = EigensolverKind;
    using S = FactorStorage;
    const auto chol = FactorizationKind::cholmod;
    const auto sym = DistributedFactorizationKind::mumps_cholesky, lu = DistributedFactorizationKind::mumps_lu;
    const std::pair<Case, std::string> cases[] = {
      {{false, E::automatic, S::automatic, chol, sym, false, true, true, true}, " (auto: the predicted factor fits the limit)"},
      {{false, E::automatic, S::memory, chol, sym, false, false, true, true}, " (auto: predicted factor 2 GB over the limit 1 GB)"},
      {{false, E::automatic, S::automatic, chol, sym, true, false, true, true}, " (auto: predicted factor 2 GB over the limit 1 GB)"},
      {{true, E::automatic, S::automatic, chol, sym, false, true, false, true},
       " (auto: the factor on disk, its in-core data fits the limit)"},
      {{true, E::automatic, S::automatic, chol, sym, false, true, false, false},
       " (auto: predicted in-core data with the factor on disk 2.2 GB over the limit 2 GB)"},
      {{true, E::automatic, S::memory, chol, sym, false, true, false, true}, " (auto: predicted factor 2.4 GB over the limit 2 GB)"},
      {{true, E::automatic, S::automatic, chol, lu, false, true, false, false}, " (auto: the predicted factor fits the limit)"},
      {{false, E::automatic, S::automatic, chol, sym, false, false, false, true},
       " (auto: the factor on disk, its in-core data fits the limit) [MUMPS on one process, for the serial run: "
       "'Modes/Factor storage = auto': CHOLMOD's analysis predicts a factor of 2 GB, 'Modes/Factor memory limit' is 1 GB]"},
      {{false, E::block_krylov, S::disk, chol, sym, false, true, true, true},
       " [MUMPS on one process, for the serial run: 'Modes/Factor storage = disk']"},
      {{false, E::block_krylov, S::automatic, chol, sym, false, true, true, true}, ""},
    };
    for (const auto &[c, words] : cases)
      check(note(c) == words, c.name() + ": the note '" + note(c) + "' is '" + words + "'");

    // A free part with 'Factor storage = disk' (test_lobpcg_amg) is refused naming that setting.
    Known free{{E::block_krylov, S::disk, chol, sym}, true, true, {}, {}};
    check(choose(free).refusal.find("Factor storage = disk") != std::string::npos, "the free part's refusal names 'Factor storage = disk'");
  }
} // namespace

int main()
{
  using E = EigensolverKind;
  using S = FactorStorage;
  int n = 0;
  for (const bool distributed : {false, true})
    for (const E e : {E::automatic, E::block_krylov, E::arpack, E::lobpcg_amg})
      for (const S s : {S::automatic, S::memory, S::disk})
        for (const auto f : {FactorizationKind::cholmod, FactorizationKind::umfpack})
          for (const auto d : {DistributedFactorizationKind::mumps_cholesky, DistributedFactorizationKind::mumps_lu})
            for (const bool free : {false, true})
              for (const bool cholmod_fits : {true, false})
                for (const bool in_core_fits : {true, false})
                  for (const bool out_of_core_fits : {true, false})
                    {
                      check_case({distributed, e, s, f, d, free, cholmod_fits, in_core_fits, out_of_core_fits});
                      ++n;
                    }
  check_words();
  std::printf("%d cases, %d checks, %d failed\n", n, checks, failures);
  return failures == 0 ? 0 : 1;
}
