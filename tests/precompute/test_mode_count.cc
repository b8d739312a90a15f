// The mode-count rule (precompute/solvers/mode_count.h) without any solve: a fake eigensolver hands
// out the lowest n of a known spectrum. Whatever the spectrum and the rule, the modes the cut-off
// keeps from the early-stopped eigensolve must be those it keeps from 'Maximum number of modes'
// (what the precompute computed before), and the eigensolve must ask for far fewer modes where
// the cut-off drops most of them.
#include "solvers/mode_count.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace
{
  using modal_haptics::ModeCountRule;
  int failures = 0;

  void check(const bool ok, const std::string &what)
  {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
    failures += !ok;
  }

  double lambda_of_hz(const double f) { return std::pow(2. * M_PI * f, 2); }

  // The oracle: space_parts::select_modes's rule (ascending eigenvalues; a mode above the cut-off is
  // dropped once the minimum is kept).
  unsigned int kept_count(const ModeCountRule &rule, const std::vector<double> &ascending)
  {
    unsigned int kept = 0;
    for (const double lambda : ascending)
      if (!(lambda > rule.cut_off_eigenvalue && kept >= rule.minimum))
        ++kept;
    return kept;
  }

  struct Run
  {
    unsigned int              calls = 0;
    std::vector<unsigned int> asked;
    std::vector<double>       last;
  };

  Run run(const ModeCountRule &rule, const std::vector<double> &spectrum)
  {
    Run r;
    r.calls = modal_haptics::solve_until_cut_off_decided(rule, [&](const unsigned int n) {
      r.asked.push_back(n);
      r.last.assign(spectrum.begin(), spectrum.begin() + std::min<std::size_t>(n, spectrum.size()));
      return r.last;
    });
    return r;
  }

  // lambda_k growing as k^(2/3) (Weyl's law in 3D), the first at f1 [Hz], after n_rigid zeros.
  std::vector<double> weyl_spectrum(const double f1, const unsigned int count, const unsigned int n_rigid = 0)
  {
    std::vector<double> s(n_rigid, 0.);
    for (unsigned int k = 1; s.size() < count; ++k)
      s.push_back(lambda_of_hz(f1) * std::pow(double(k), 2. / 3.));
    return s;
  }

  // The early-stopped eigensolve keeps what the full one keeps.
  bool keeps_the_same(const ModeCountRule &rule, const std::vector<double> &spectrum, const Run &r)
  {
    const std::vector<double> full(spectrum.begin(), spectrum.begin() + std::min<std::size_t>(rule.maximum, spectrum.size()));
    return kept_count(rule, r.last) == kept_count(rule, full);
  }

  void default_scene_like()
  {
    // 4 modes below 500 Hz, minimum 10: the 10th lies above the cut-off, one eigensolve of 10.
    const ModeCountRule rule{10, 50, lambda_of_hz(500.)};
    const auto          spectrum = weyl_spectrum(300., 100); // f_k = 300 k^(1/3) Hz: 4 below 500 Hz
    const Run           r        = run(rule, spectrum);
    check(r.calls == 1 && r.asked.front() == 10, "cut-off below the 10th mode: one eigensolve of 10 modes (asked " +
                                                   std::to_string(r.asked.front()) + ")");
    check(keeps_the_same(rule, spectrum, r) && kept_count(rule, r.last) == 10, "keeps the minimum, 10");
    check(rule.why_decided(r.last).find("above the cut-off") != std::string::npos, "says why: " + rule.why_decided(r.last));
  }

  void many_modes_below_the_cut_off()
  {
    // 30 modes below the cut-off: the first 10 are not enough, Weyl's estimate asks for more.
    const auto          spectrum = weyl_spectrum(100., 200);
    const double        cut      = std::sqrt(spectrum[29] * spectrum[30]); // between the 30th and 31st
    const ModeCountRule rule{10, 50, cut};
    const Run           r = run(rule, spectrum);
    check(rule.decided(r.last) && r.last.back() > cut, "decided with a mode above the cut-off");
    check(keeps_the_same(rule, spectrum, r) && kept_count(rule, r.last) == 30, "keeps the 30 below the cut-off");
    check(r.calls == 2 && r.asked.back() < 50, "two eigensolves, the second of " + std::to_string(r.asked.back()) +
                                                 " < 50 modes");
  }

  void no_cut_off_and_maximum()
  {
    const auto spectrum = weyl_spectrum(100., 200);
    const Run  none     = run(ModeCountRule{10, 50}, spectrum);
    check(none.calls == 1 && none.asked.front() == 50, "'Cut-off rule = none': the maximum at once");
    const Run capped = run(ModeCountRule{10, 50, lambda_of_hz(1e6)}, spectrum);
    check(capped.last.size() == 50 && kept_count(ModeCountRule{10, 50, lambda_of_hz(1e6)}, capped.last) == 50,
          "every mode below the cut-off: stops at the maximum, " + std::to_string(capped.calls) + " eigensolves");
  }

  void rigid_modes_and_short_solvers()
  {
    // A free part: six zeros first, then elastic modes; minimum 10.
    const auto          spectrum = weyl_spectrum(300., 100, 6);
    const ModeCountRule rule{10, 50, lambda_of_hz(500.)};
    const Run           r = run(rule, spectrum);
    check(keeps_the_same(rule, spectrum, r), "six rigid-body modes: keeps what the full eigensolve keeps");
    // A solver that finds fewer than asked (too few unknowns) ends the loop.
    const std::vector<double> short_spectrum = weyl_spectrum(10., 7);
    const Run                 s              = run(ModeCountRule{10, 50, lambda_of_hz(500.)}, short_spectrum);
    check(s.calls == 1 && s.last.size() == 7, "a solver returning fewer than asked is not asked again");
    check(ModeCountRule{0, 50, lambda_of_hz(500.)}.first_count() == 1, "minimum 0: asks for one mode first");
  }

  // A random spectrum of a part: after up to six rigid-body zeros, counts growing as lambda^p with
  // p in [1/4, 3/2] (beams to solids), each eigenvalue jittered by up to 10 % (and sorted), a
  // quarter of them doubled (symmetric parts); or, with 'wild', any increasing sequence.
  std::vector<double> random_spectrum(std::mt19937_64 &random, const bool wild)
  {
    std::uniform_real_distribution<double> uniform(0., 1.);
    std::vector<double> spectrum(uniform(random) < 0.2 ? unsigned(7 * uniform(random)) : 0u, 0.);
    const double        lambda_1 = lambda_of_hz(10. + 500. * uniform(random)), p = 0.25 + 1.25 * uniform(random);
    double              lambda   = lambda_1;
    for (unsigned int k = 1; spectrum.size() < 300; ++k)
      {
        lambda = wild ? lambda * (1. + 0.3 * uniform(random) * uniform(random)) :
                        lambda_1 * std::pow(double(k), 1. / p) * (1. + 0.1 * uniform(random));
        spectrum.push_back(lambda);
        if (!wild && uniform(random) < 0.25)
          spectrum.push_back(lambda);
      }
    std::sort(spectrum.begin(), spectrum.end());
    spectrum.resize(300);
    return spectrum;
  }

  // Random spectra and rules: always the same kept count as the full eigensolve; never more than
  // three times the maximum's modes asked over all eigensolves; and, on parts' spectra, at most two
  // eigensolves in 95 % of the cases, and where the cut-off keeps at most half the maximum, a last
  // eigensolve of fewer than the maximum in 90 %.
  void random_spectra()
  {
    std::mt19937_64 random(36);
    unsigned int    same = 0, cases = 4000, fewer = 0, dropping = 0, bounded = 0, parts = 0, at_most_two = 0;
    for (unsigned int c = 0; c < cases; ++c)
      {
        std::uniform_real_distribution<double> uniform(0., 1.);
        const bool                             wild     = c % 2 == 1;
        const std::vector<double>              spectrum = random_spectrum(random, wild);
        const unsigned int  maximum = 1 + unsigned(120 * uniform(random));
        const unsigned int  minimum = unsigned(std::min(maximum, unsigned(20 * uniform(random))));
        const ModeCountRule rule{minimum, maximum, lambda_of_hz(2000. * uniform(random))};
        const Run           r = run(rule, spectrum);
        same += keeps_the_same(rule, spectrum, r);
        unsigned int asked = 0;
        for (const unsigned int n : r.asked)
          asked += n;
        bounded += asked <= 3 * maximum;
        if (!wild)
          {
            ++parts;
            at_most_two += r.calls <= 2;
          }
        const std::vector<double> full(spectrum.begin(), spectrum.begin() + maximum);
        if (!wild && 2 * kept_count(rule, full) <= maximum && maximum >= 2 * ModeCountRule::minimum_growth)
          {
            ++dropping;
            fewer += r.asked.back() < maximum;
          }
      }
    check(same == cases, std::to_string(same) + " of " + std::to_string(cases) +
                           " random rules keep what the full eigensolve keeps");
    check(bounded == cases, std::to_string(bounded) + " of " + std::to_string(cases) +
                              " ask for at most three times the maximum over all their eigensolves");
    check(at_most_two >= parts * 95 / 100,
          std::to_string(at_most_two) + " of " + std::to_string(parts) + " parts' spectra decided in at most two eigensolves");
    check(fewer >= dropping * 9 / 10, std::to_string(fewer) + " of " + std::to_string(dropping) +
                                        " parts' spectra that keep at most half the maximum ask for fewer than the maximum");
  }
} // namespace

int main()
{
  default_scene_like();
  many_modes_below_the_cut_off();
  no_cut_off_and_maximum();
  rigid_modes_and_short_solvers();
  random_spectra();
  std::printf("%s\n", failures == 0 ? "all passed" : "FAILURES");
  return failures == 0 ? 0 : 1;
}
