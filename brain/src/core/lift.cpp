#include "pete/core/lift.hpp"

namespace pete::core {

const char* to_string(LiftEvent e) {
  switch (e) {
    case LiftEvent::none:
      return "none";
    case LiftEvent::jetson_raised:
      return "lift raised by the Jetson";
    case LiftEvent::jetson_lowered:
      return "lift lowered by the Jetson";
    case LiftEvent::driver_raised:
      return "lift raised by the driver";
    case LiftEvent::driver_lowered:
      return "lift lowered by the driver";
  }
  return "?";
}

LiftEvent LiftControl::update(msg::MatchPhase phase, bool button, msg::LiftAction command) {
  const bool driver = phase == msg::MatchPhase::driver;
  const bool press = driver && button && !button_was_;
  button_was_ = driver && button;
  const bool fresh = command != last_command_;
  last_command_ = command;
  if (phase == msg::MatchPhase::disabled) return LiftEvent::none;
  if (press) {
    up_ = !up_;
    return up_ ? LiftEvent::driver_raised : LiftEvent::driver_lowered;
  }
  if (fresh && command == msg::LiftAction::up && !up_) {
    up_ = true;
    return LiftEvent::jetson_raised;
  }
  if (fresh && command == msg::LiftAction::down && up_) {
    up_ = false;
    return LiftEvent::jetson_lowered;
  }
  return LiftEvent::none;
}

}  // namespace pete::core
