// The match clock PROS does not have: the phase (disabled / autonomous / driver) and how long it
// has lasted, from pros::competition's status bits timed with millis(); and where a VEX AI match
// is: before it, the isolation period (autonomous, 15 s), the disable between the periods (pause),
// the interaction period (driver control, 105 s), after it.
//
//   before --autonomous--> isolation --disabled--> pause --driver--> interaction --disabled--> after
//
//   - A driver-control phase straight from before or after is an interaction period of a new
//     match with no isolation (a bench test, skills); an autonomous phase from before, after or
//     interaction begins a new match.
//   - A disable in the interaction period is its end (after) once the period has run its length
//     less kEndSlackMs; earlier, it is a pause (a field fault), and the next driver-control phase
//     goes on with the same interaction period.
//   - A re-enable into autonomous during isolation or its pause goes on with the same isolation.
//   - match_ms runs on the match's nominal 120-s clock: isolation 0..isolation_ms, interaction
//     isolation_ms..isolation_ms + interaction_ms; it holds still in pause and after.
#pragma once

#include <cstdint>

#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::core {

/// The phase the status bits mean. Without a competition switch PROS reports enabled driver
/// control, which is what this returns.
msg::MatchPhase phase_of(const CompetitionStatus& status);

/// The lengths of a VEX AI match's periods.
struct MatchTiming {
  uint32_t isolation_ms = 15000;
  uint32_t interaction_ms = 105000;
};

class MatchClock {
 public:
  /// A disable this close to the end of the interaction period ends the match.
  static constexpr uint32_t kEndSlackMs = 5000;

  MatchClock() = default;
  explicit MatchClock(const MatchTiming& timing) : timing_(timing) {}

  /// Feed the competition status once per loop step. Returns true when a phase began: the first
  /// update, and every change after it. A re-enable into autonomous is a new phase whose clock
  /// starts again at zero, just as PROS restarts autonomous() from the top.
  bool update(const CompetitionStatus& status, uint32_t now_ms);

  msg::MatchPhase phase() const { return phase_; }
  /// Milliseconds since the current phase began (0 before the first update).
  uint32_t phase_ms(uint32_t now_ms) const { return started_ ? now_ms - start_ms_ : 0; }
  /// How many phases have begun, counting the first.
  uint32_t phases_begun() const { return phases_begun_; }

  msg::MatchPeriod period() const { return period_; }
  /// Time into the match on its nominal clock (see above).
  uint32_t match_ms(uint32_t now_ms) const;
  /// How many matches have begun (a new isolation, or an interaction without one).
  uint32_t matches_begun() const { return matches_begun_; }
  /// True when the last phase to begin also began a match.
  bool match_began() const { return match_began_; }

 private:
  MatchTiming timing_;
  msg::MatchPhase phase_ = msg::MatchPhase::disabled;
  uint32_t start_ms_ = 0;
  uint32_t phases_begun_ = 0;
  bool started_ = false;

  msg::MatchPeriod period_ = msg::MatchPeriod::before;
  bool interaction_begun_ = false;   // this match's interaction period has begun
  uint32_t interaction_done_ms_ = 0; // interaction time before the current phase
  uint32_t held_ms_ = 0;             // match_ms while it holds still (pause, after)
  uint32_t matches_begun_ = 0;
  bool match_began_ = false;
};

}  // namespace pete::core
