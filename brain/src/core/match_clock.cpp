#include "pete/core/match_clock.hpp"

namespace pete::core {

msg::MatchPhase phase_of(const CompetitionStatus& status) {
  if (!status.enabled) return msg::MatchPhase::disabled;
  return status.autonomous ? msg::MatchPhase::autonomous : msg::MatchPhase::driver;
}

uint32_t MatchClock::match_ms(uint32_t now_ms) const {
  const uint32_t t = phase_ms(now_ms);
  switch (period_) {
    case msg::MatchPeriod::isolation:
      return t < timing_.isolation_ms ? t : timing_.isolation_ms;
    case msg::MatchPeriod::interaction: {
      const uint32_t in = interaction_done_ms_ + t;
      return timing_.isolation_ms + (in < timing_.interaction_ms ? in : timing_.interaction_ms);
    }
    case msg::MatchPeriod::pause:
    case msg::MatchPeriod::after:
      return held_ms_;
    case msg::MatchPeriod::before:
      break;
  }
  return 0;
}

bool MatchClock::update(const CompetitionStatus& status, uint32_t now_ms) {
  const msg::MatchPhase phase = phase_of(status);
  if (started_ && phase == phase_) return false;
  // The period the phase that ends leaves behind (match_ms holds its last value from here).
  const uint32_t held = match_ms(now_ms);
  const uint32_t ended_ms = phase_ms(now_ms);
  match_began_ = false;
  switch (phase) {
    case msg::MatchPhase::disabled:
      if (period_ == msg::MatchPeriod::isolation) {
        period_ = msg::MatchPeriod::pause;
      } else if (period_ == msg::MatchPeriod::interaction) {
        interaction_done_ms_ += ended_ms;
        const bool ran_out = interaction_done_ms_ + kEndSlackMs >= timing_.interaction_ms;
        period_ = ran_out ? msg::MatchPeriod::after : msg::MatchPeriod::pause;
      }
      held_ms_ = held;
      break;
    case msg::MatchPhase::autonomous: {
      const bool same_match = (period_ == msg::MatchPeriod::isolation ||
                               period_ == msg::MatchPeriod::pause) &&
                              !interaction_begun_;
      if (!same_match) {
        match_began_ = true;
        ++matches_begun_;
        interaction_begun_ = false;
        interaction_done_ms_ = 0;
      }
      period_ = msg::MatchPeriod::isolation;
      break;
    }
    case msg::MatchPhase::driver: {
      const bool same_match =
          period_ == msg::MatchPeriod::isolation || period_ == msg::MatchPeriod::pause;
      if (!same_match) {
        match_began_ = true;
        ++matches_begun_;
        interaction_done_ms_ = 0;
      }
      interaction_begun_ = true;
      period_ = msg::MatchPeriod::interaction;
      break;
    }
  }
  phase_ = phase;
  start_ms_ = now_ms;
  started_ = true;
  ++phases_begun_;
  return true;
}

}  // namespace pete::core
