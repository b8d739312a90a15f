// How many of the lowest modes a space's eigensolve computes: only those the cut-off rule keeps,
// and one more to be sure of it, instead of 'Modes/Maximum number of modes' of which most would be
// dropped (issue 36: the default scene kept 10 of 50 in every space).
//
// The cut-off keeps the first max(minimum, number below the cut-off) modes, at most the maximum
// (space_parts::select_modes). That count is decided once the lowest n modes are known with n at
// least the minimum and the n-th above the cut-off: every later mode is above it too. So an
// eigensolve asks for the lowest n, and when the n-th still lies below the cut-off asks again for
// more, estimated from the spectrum found so far. Shift-invert Krylov methods converge the modes
// nearest the shift (the lowest) first, the trust every count of computed modes already rests on.
//
// No deal.II here: the rule is a value and is tested without solving anything
// (tests/precompute/test_mode_count.cc).
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace modal_haptics
{
  struct ModeCountRule
  {
    unsigned int minimum = 10;
    unsigned int maximum = 50;
    // lambda = (2 pi f_cut)^2 [rad^2/s^2]; +inf: no cut-off, every one of the maximum is kept.
    double cut_off_eigenvalue = std::numeric_limits<double>::infinity();

    // The count the first eigensolve asks for.
    unsigned int first_count() const;
    // Whether the ascending lowest eigenvalues decide the cut-off's count.
    bool decided(const std::vector<double> &ascending) const;
    // The count to ask for next when they do not: the modes below the cut-off estimated from the
    // spectrum found so far, whose count grows as lambda^p (Weyl: p = 3/2 for a solid, less for the
    // bending of plates and beams, p measured between the middle and the highest mode found and
    // kept within [1/4, 3/2]), with a quarter more as margin, at least 'minimum_growth' more and at
    // least half again as many; the maximum itself once that is within a fifth of it.
    unsigned int next_count(const std::vector<double> &ascending) const;
    // The log's words for a decided count: "the 11th mode (612 Hz) lies above the cut-off 500 Hz".
    std::string why_decided(const std::vector<double> &ascending) const;

    static constexpr unsigned int minimum_growth = 4;
  };

  // Calls solve_lowest(n) for the lowest n modes, with n growing, until the rule is decided on the
  // eigenvalues it returns (ascending, rad^2/s^2); returns how many calls it took. solve_lowest
  // keeps its last solution itself.
  unsigned int solve_until_cut_off_decided(const ModeCountRule                                         &rule,
                                           const std::function<std::vector<double>(unsigned int n)> &solve_lowest);
} // namespace modal_haptics
