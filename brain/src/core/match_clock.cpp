#include "pete/core/match_clock.hpp"

namespace pete::core {

msg::MatchPhase phase_of(const CompetitionStatus& status) {
  if (!status.enabled) return msg::MatchPhase::disabled;
  return status.autonomous ? msg::MatchPhase::autonomous : msg::MatchPhase::driver;
}

bool MatchClock::update(const CompetitionStatus& status, uint32_t now_ms) {
  const msg::MatchPhase phase = phase_of(status);
  if (started_ && phase == phase_) return false;
  phase_ = phase;
  start_ms_ = now_ms;
  started_ = true;
  ++phases_begun_;
  return true;
}

}  // namespace pete::core
