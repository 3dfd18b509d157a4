#include "pete/core/clamp.hpp"

namespace pete::core {

const char* to_string(ClampEvent e) {
  switch (e) {
    case ClampEvent::none:
      return "none";
    case ClampEvent::auto_closed:
      return "clamp closed on a goal";
    case ClampEvent::driver_closed:
      return "clamp closed by the driver";
    case ClampEvent::driver_opened:
      return "clamp opened by the driver";
  }
  return "?";
}

ClampEvent ClampControl::update(msg::MatchPhase phase, uint8_t sensed, bool button,
                                uint32_t now_ms) {
  // Only 0 and 1 are readings; anything else (kClampUnknown, or a broken adapter) is no sensor.
  const bool fitted = sensed == 0 || sensed == 1;
  const bool goal = sensed == 1;
  if (!goal) {
    goal_seen_ = false;
    armed_ = true;  // the back is empty: the next goal may be grabbed
  } else if (!goal_seen_) {
    goal_seen_ = true;
    goal_since_ms_ = now_ms;
  }

  ClampEvent event = ClampEvent::none;
  const bool press = phase == msg::MatchPhase::driver && button && !button_was_;
  button_was_ = phase == msg::MatchPhase::driver && button;
  if (press) {
    closed_ = !closed_;
    if (closed_) {
      event = ClampEvent::driver_closed;
    } else {
      event = ClampEvent::driver_opened;
      armed_ = !goal;  // do not re-grab the goal the driver just let go of
    }
  } else if (!closed_ && config_.auto_close && armed_ && goal &&
             phase != msg::MatchPhase::disabled && now_ms - goal_since_ms_ >= config_.confirm_ms) {
    closed_ = true;
    event = ClampEvent::auto_closed;
  }

  goal_clamped_ = !fitted ? kClampUnknown : (closed_ && goal ? 1 : 0);
  return event;
}

}  // namespace pete::core
