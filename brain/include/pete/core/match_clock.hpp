// The match clock PROS does not have: the phase (disabled / autonomous / driver) and how long it
// has lasted, from pros::competition's status bits timed with millis().
#pragma once

#include <cstdint>

#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::core {

/// The phase the status bits mean. Without a competition switch PROS reports enabled driver
/// control, which is what this returns.
msg::MatchPhase phase_of(const CompetitionStatus& status);

class MatchClock {
 public:
  /// Feed the competition status once per loop step. Returns true when a phase began: the first
  /// update, and every change after it. A re-enable into autonomous is a new phase whose clock
  /// starts again at zero, just as PROS restarts autonomous() from the top.
  bool update(const CompetitionStatus& status, uint32_t now_ms);

  msg::MatchPhase phase() const { return phase_; }
  /// Milliseconds since the current phase began (0 before the first update).
  uint32_t phase_ms(uint32_t now_ms) const { return started_ ? now_ms - start_ms_ : 0; }
  /// How many phases have begun, counting the first.
  uint32_t phases_begun() const { return phases_begun_; }

 private:
  msg::MatchPhase phase_ = msg::MatchPhase::disabled;
  uint32_t start_ms_ = 0;
  uint32_t phases_begun_ = 0;
  bool started_ = false;
};

}  // namespace pete::core
