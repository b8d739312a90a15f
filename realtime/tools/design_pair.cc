#include "design_pair.h"

#include "run_loop.h"
#include "run_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

namespace modalrt_tool
{
  DesignBlend::DesignBlend(double fade_ticks, double rate_limit)
    : step_(1.0 / std::max(1.0, fade_ticks)), rate_limit_(rate_limit)
  {}

  void DesignBlend::blend(const modalrt_hip_output *a, const modalrt_hip_output *b, std::uint32_t hips,
                          modalrt_hip_output *out)
  {
    if (share_b_ != target_)
      {
        // The blend's own change of the force is |F_b - F_a| per unit of share: slower where the two
        // designs' forces differ by more than rate_limit / step.
        double largest_difference = 0.0;
        for (std::uint32_t h = 0; h < hips; ++h)
          for (int d = 0; d < 3; ++d)
            largest_difference = std::max(largest_difference, std::abs(b[h].force[d] - a[h].force[d]));
        const double step = largest_difference > 0.0 ? std::min(step_, rate_limit_ / largest_difference) : step_;
        share_b_          = target_ > share_b_ ? std::min(target_, share_b_ + step) : std::max(target_, share_b_ - step);
      }
    const double w = share_b_;
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        out[h] = front() == 1 ? b[h] : a[h];
        for (int d = 0; d < 3; ++d)
          {
            out[h].position[d] = (1.0 - w) * a[h].position[d] + w * b[h].position[d];
            out[h].velocity[d] = (1.0 - w) * a[h].velocity[d] + w * b[h].velocity[d];
            out[h].force[d]    = (1.0 - w) * a[h].force[d] + w * b[h].force[d];
          }
      }
  }

  std::uint32_t BlindTrial::stiffer_slot() const
  {
    if (!(stiffness[0] > 0.0 && stiffness[1] > 0.0) || stiffness[0] == stiffness[1])
      return 0;
    return stiffness[0] > stiffness[1] ? 1 : 2;
  }

  BlindTrials::BlindTrials(std::size_t trials, std::uint32_t seed) : trials_(trials)
  {
    std::mt19937 draw(seed); // the engine's sequence is fixed by the standard: the same order everywhere
    for (BlindTrial &trial : trials_)
      trial.slot1_design = std::uint32_t(draw() >> 31);
  }

  void BlindTrials::begin(double t)
  {
    if (current_ < trials_.size())
      trials_[current_].start = t;
    ++current_;
    slot_ = 0;
  }

  std::uint32_t BlindTrials::design_of(std::uint32_t slot) const
  {
    if (current_ == 0 || current_ > trials_.size())
      return 0;
    return trials_[current_ - 1].design_in(slot);
  }

  void BlindTrials::observe(double stiffness)
  {
    if (current_ == 0 || current_ > trials_.size() || slot_ == 0 || !(stiffness > 0.0))
      return;
    trials_[current_ - 1].stiffness[slot_ - 1] = stiffness;
  }

  void BlindTrials::answer(std::uint32_t slot, double t)
  {
    if (current_ == 0 || current_ > trials_.size())
      return;
    trials_[current_ - 1].answer      = slot;
    trials_[current_ - 1].answer_time = t;
  }

  HapticResult trace_of_design(const HapticResult &result, std::uint32_t hips, std::uint32_t design)
  {
    HapticResult own = result;
    for (TraceSample &s : own.trace)
      if (s.design != design || (s.design_share > 0.0f && s.design_share < 1.0f))
        {
          s.in_contact    = 0;
          s.active_vertex = MODALRT_NONE;
        }
    // A slide belongs to the design in front at its first trace row at or after its start.
    const auto design_at = [&](const Slide &slide) {
      const std::size_t rows = hips ? result.trace.size() / hips : 0;
      for (std::size_t r = 0; r < rows; ++r)
        if (result.trace[r * hips + slide.hip].time >= slide.start)
          return result.trace[r * hips + slide.hip].design;
      return std::uint32_t(0);
    };
    own.slides.erase(std::remove_if(own.slides.begin(), own.slides.end(),
                                    [&](const Slide &slide) { return design_at(slide) != design; }),
                     own.slides.end());
    return own;
  }

  bool write_blind_log(const std::string &path, const std::vector<BlindTrial> &trials, std::string &error)
  {
    std::string text = "# modal-rt run blind A/B trials: per trial its start [s], the design in each slot (A: "
                       "--basis, B: --design-b), each slot's felt-stiffness map value at the contact last pressed "
                       "while it was felt [N/mm] (full FE; nan: not pressed), the user's answer (the slot said to "
                       "feel stiffer; 0: none) and its time [s], the design answered, the stiffer slot by the maps "
                       "(0: not both pressed, or equal) and whether the answer was right (1), wrong (0) or cannot "
                       "be scored (-1)\n"
                       "trial,start_s,slot1_design,slot2_design,slot1_stiffness_n_per_mm,slot2_stiffness_n_per_mm,"
                       "answer_slot,answer_time_s,answer_design,stiffer_slot,correct\n";
    char line[320];
    for (std::size_t k = 0; k < trials.size(); ++k)
      {
        const BlindTrial   &t       = trials[k];
        const std::uint32_t stiffer = t.stiffer_slot();
        const int correct = t.answer == 0 || stiffer == 0 ? -1 : t.answer == stiffer ? 1 : 0;
        const auto per_mm = [](double k_n_per_m) { return k_n_per_m > 0.0 ? 1e-3 * k_n_per_m : std::nan(""); };
        std::snprintf(line, sizeof line, "%zu,%.9g,%c,%c,%.9g,%.9g,%u,%.9g,%s,%u,%d\n", k + 1, t.start,
                      "AB"[t.design_in(1)], "AB"[t.design_in(2)], per_mm(t.stiffness[0]), per_mm(t.stiffness[1]),
                      t.answer, t.answer ? t.answer_time : std::nan(""),
                      t.answer ? (t.design_in(t.answer) ? "B" : "A") : "", stiffer, correct);
        text += line;
      }
    return write_file_atomically(path, text, error);
  }

  BlindScore score(const std::vector<BlindTrial> &trials)
  {
    BlindScore s;
    for (const BlindTrial &t : trials)
      if (t.answer != 0 && t.stiffer_slot() != 0)
        {
          ++s.answered;
          s.correct += t.answer == t.stiffer_slot();
        }
    // P(X >= correct) for X ~ Binomial(answered, 1/2).
    double tail = 0.0, term = std::pow(0.5, double(s.answered)); // C(n, 0) / 2^n
    for (std::uint32_t k = 0; k <= s.answered; ++k)
      {
        if (k >= s.correct)
          tail += term;
        term *= double(s.answered - k) / double(k + 1);
      }
    s.chance = s.answered ? std::min(1.0, tail) : 1.0;
    return s;
  }
} // namespace modalrt_tool
