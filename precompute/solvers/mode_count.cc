#include "solvers/mode_count.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace modal_haptics
{
  namespace
  {
    double hz(const double lambda) { return std::sqrt(std::max(lambda, 0.)) / (2. * M_PI); }

    // p of count ~ lambda^p between the elastic mode halfway up and the highest found.
    double growth_exponent(const std::vector<double> &ascending)
    {
      const std::size_t n = ascending.size(), middle = n / 2;
      if (middle == 0 || ascending[middle - 1] <= 0. || ascending[n - 1] <= ascending[middle - 1])
        return 1.5;
      const double p = std::log(double(n) / double(middle)) / std::log(ascending[n - 1] / ascending[middle - 1]);
      return std::clamp(p, 0.25, 1.5);
    }
  } // namespace

  unsigned int ModeCountRule::first_count() const
  {
    if (std::isinf(cut_off_eigenvalue))
      return maximum;
    return std::min(maximum, std::max(minimum, 1u));
  }

  bool ModeCountRule::decided(const std::vector<double> &ascending) const
  {
    if (ascending.size() >= maximum)
      return true;
    return ascending.size() >= minimum && !ascending.empty() && ascending.back() > cut_off_eigenvalue;
  }

  unsigned int ModeCountRule::next_count(const std::vector<double> &ascending) const
  {
    const std::size_t n       = ascending.size();
    const double      highest = n == 0 ? 0. : ascending.back();
    // Rigid-body modes alone (lambda <= 0) say nothing of the elastic spectrum's density: double.
    const double estimate =
      highest > 0. ? 1.25 * double(n) * std::pow(cut_off_eigenvalue / highest, growth_exponent(ascending)) + 1. :
                     2. * double(n);
    // At least half again as many: an estimate that falls short again and again costs a geometric
    // series. Within a fifth of the maximum, the maximum itself: it costs little more than the
    // estimate and spares a third eigensolve should the estimate fall short.
    const double wanted = std::max({estimate, double(n + minimum_growth), 1.5 * double(n)});
    return wanted >= 0.8 * maximum ? maximum : unsigned(std::ceil(wanted));
  }

  std::string ModeCountRule::why_decided(const std::vector<double> &ascending) const
  {
    std::ostringstream why;
    const std::size_t  n = ascending.size();
    if (n > 0 && ascending.back() > cut_off_eigenvalue)
      why << "mode " << n << " (" << hz(ascending.back()) << " Hz) lies above the cut-off " << hz(cut_off_eigenvalue)
          << " Hz";
    else
      why << "'Modes/Maximum number of modes' = " << maximum << " reached"
          << (std::isinf(cut_off_eigenvalue) ? " ('Modes/Cut-off rule' = none)" : " below the cut-off");
    return why.str();
  }

  unsigned int solve_until_cut_off_decided(const ModeCountRule                                         &rule,
                                           const std::function<std::vector<double>(unsigned int n)> &solve_lowest)
  {
    unsigned int n = rule.first_count(), calls = 0;
    while (true)
      {
        const std::vector<double> ascending = solve_lowest(n);
        ++calls;
        // A solver that returned fewer than asked is done: asking again would not give more.
        if (rule.decided(ascending) || ascending.size() < n)
          return calls;
        n = rule.next_count(ascending);
      }
  }
} // namespace modal_haptics
