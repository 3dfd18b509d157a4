// The lift that puts rings on a goal's high branch: up or down, as the Jetson's Command.lift or
// the driver's button says; nothing else moves it.
//
//   - While the Jetson drives, Command.lift `up` raises it, `down` lowers it, `leave` leaves it;
//     up or down acts when the Command's value changes (or the Jetson takes the drive back), so a
//     Jetson repeating itself does not undo the driver's button.
//   - In driver control each press of the lift button (R2) toggles it.
//   - A disabled robot keeps it as it is (a piston holds; the V5 cuts a motor's power anyway).
//
// Every State reports `lift`: up, down, or absent when none is fitted.
#pragma once

#include <cstdint>

#include "pete/messages.hpp"

namespace pete::core {

enum class LiftEvent : uint8_t { none, jetson_raised, jetson_lowered, driver_raised, driver_lowered };

/// For the Log line the robot sends on each event.
const char* to_string(LiftEvent e);

class LiftControl {
 public:
  /// One loop step. `button`: the driver holds the lift button (read only in driver control);
  /// `command`: the Jetson's Command.lift while the Jetson drives (leave otherwise).
  LiftEvent update(msg::MatchPhase phase, bool button, msg::LiftAction command);

  bool up() const { return up_; }

 private:
  bool up_ = false;
  bool button_was_ = false;
  msg::LiftAction last_command_ = msg::LiftAction::leave;
};

}  // namespace pete::core
