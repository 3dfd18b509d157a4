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
    case ClampEvent::jetson_closed:
      return "clamp closed by the Jetson";
    case ClampEvent::jetson_opened:
      return "clamp opened by the Jetson";
  }
  return "?";
}

ClampEvent ClampControl::update(msg::MatchPhase phase, uint8_t sensed, bool button,
                                msg::ClampAction command, uint32_t now_ms) {
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

  // The Jetson's hold or release acts when it changes (a Command repeating itself does not undo
  // the driver's button); release keeps auto close off for as long as it is commanded.
  const bool fresh = command != last_command_;
  last_command_ = command;

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
  } else if (phase == msg::MatchPhase::disabled) {
    // A disabled robot moves nothing: the clamp stays as it is.
  } else if (command == msg::ClampAction::hold) {
    if (fresh && !closed_) {
      closed_ = true;
      event = ClampEvent::jetson_closed;
    }
  } else if (command == msg::ClampAction::release) {
    if (fresh && closed_) {
      closed_ = false;
      event = ClampEvent::jetson_opened;
    }
    armed_ = !goal;  // when the Jetson stops saying release, do not re-grab this goal
  } else if (!closed_ && config_.auto_close && armed_ && goal &&
             now_ms - goal_since_ms_ >= config_.confirm_ms) {
    closed_ = true;
    event = ClampEvent::auto_closed;
  }

  goal_clamped_ = !fitted ? kClampUnknown : (closed_ && goal ? 1 : 0);
  return event;
}

}  // namespace pete::core
