// Two designs of a part felt one after the other (`modal-rt run --design-b FILE.mrt`): the method's
// purpose is to judge a design's local stiffness against another's before tooling.
//
// Both designs' kernels are ticked every tick with the same device inputs and the same session
// events, so each part is always in the state the same hand has pressed it into: a switch carries
// the state across by construction and only changes which kernel's output reaches the device. The
// output fades from one design's to the other's (DesignBlend), so the force never steps; the blind
// mode (BlindTrials) hides which design the hand feels and logs the user's answers with the truth.
#pragma once

#include <modalrt/modalrt.h>

#include <cstdint>
#include <string>
#include <vector>

namespace modalrt_tool
{
  struct HapticResult;

  // The hand's output as a blend of the two designs' outputs. share_b is the second design's share:
  // 0 design A, 1 design B; a switch moves it by at most one fade step per tick, and by less where
  // the two forces differ so much that the step would change the force by more than the rate limit.
  class DesignBlend
  {
  public:
    // fade_ticks: ticks from one design to the other (>= 1); rate_limit [N per tick]: the kernel's
    // force_rate_limit, the largest change of the force the blend may make in one tick.
    DesignBlend(double fade_ticks, double rate_limit);

    void          show(std::uint32_t design) { target_ = design == 1 ? 1.0 : 0.0; }
    std::uint32_t shown() const { return target_ == 1.0 ? 1 : 0; }   // the design asked for last
    std::uint32_t front() const { return share_b_ >= 0.5 ? 1 : 0; } // the design the hand mostly feels
    double        share_b() const { return share_b_; }
    bool          fading() const { return share_b_ > 0.0 && share_b_ < 1.0; }

    // One tick: moves the share toward the design shown and writes the blend of a and b into out.
    // Contact, vertex, space, flags and proxy come from the design in front.
    void blend(const modalrt_hip_output *a, const modalrt_hip_output *b, std::uint32_t hips, modalrt_hip_output *out);

  private:
    double step_;       // [-] share per tick of a fade
    double rate_limit_; // [N per tick]
    double share_b_ = 0.0, target_ = 0.0;
  };

  // One trial of the blind mode: which design sits in slot 1 (the other in slot 2), each slot's
  // felt-stiffness map value at the contact the hand last pressed while feeling it, and the answer.
  struct BlindTrial
  {
    double        start          = 0.0; // [s]
    std::uint32_t slot1_design   = 0;   // 0 design A, 1 design B
    double        stiffness[2]   = {0.0, 0.0}; // [N/m] per slot, full FE (the scene's map); 0: not pressed
    std::uint32_t answer         = 0;   // the slot the user said felt stiffer (1, 2); 0: no answer
    double        answer_time    = 0.0; // [s]

    std::uint32_t design_in(std::uint32_t slot) const { return slot == 1 ? slot1_design : 1 - slot1_design; }
    // The slot whose design is stiffer at the contacts pressed (0: not both pressed, or equal).
    std::uint32_t stiffer_slot() const;
  };

  // The blind mode's trials, drawn before the first tick from a seed (the same seed, the same order),
  // sized to the session's `trial` rows: no allocation in the haptic thread.
  class BlindTrials
  {
  public:
    BlindTrials() = default;
    BlindTrials(std::size_t trials, std::uint32_t seed);

    bool          active() const { return !trials_.empty(); }
    void          begin(double t); // the next trial
    std::uint32_t design_of(std::uint32_t slot) const; // in the current trial (design A before the first)
    void          shown(std::uint32_t slot) { slot_ = slot; }
    // A tick in contact while the slot shown is felt alone: the map value at its contact [N/m].
    void observe(double stiffness);
    void answer(std::uint32_t slot, double t);

    const std::vector<BlindTrial> &trials() const { return trials_; }

  private:
    std::vector<BlindTrial> trials_;
    std::size_t             current_ = 0; // trials begun
    std::uint32_t           slot_    = 0; // slot shown in the current trial (0: none yet)
  };

  // The trace of one design: its rows as they are, every other row (the other design in front, or a
  // fade between them) out of contact, so the presses of each design are found and referenced
  // against its own basis.
  HapticResult trace_of_design(const HapticResult &result, std::uint32_t hips, std::uint32_t design);

  // blind.csv: one row per trial (the columns are documented in realtime/README.md).
  bool write_blind_log(const std::string &path, const std::vector<BlindTrial> &trials, std::string &error);

  // The blind mode's score: answers, correct ones, and the chance of at least as many correct by
  // guessing (one-sided binomial, p = 1/2).
  struct BlindScore
  {
    std::uint32_t answered = 0, correct = 0;
    double        chance   = 1.0;
  };
  BlindScore score(const std::vector<BlindTrial> &trials);
} // namespace modalrt_tool
