// The mobile-goal clamp on the robot's back: the Jetson holds and releases it; left to itself it
// behaves as the simulator's auto clamp (sim/world/physics.py, WorldConfig.auto_clamp).
//
//   - While the Jetson drives, its Command's `clamp` decides: `hold` closes the clamp, `release`
//     opens it and keeps auto close off while Commands say release, `leave` leaves it as it is, to
//     auto close. A hold or release acts when the Command's value changes (or the Jetson takes
//     the drive back), so a Jetson repeating itself does not undo the driver's button.
//   - While the robot is enabled (autonomous or driver control) and the sensor at the back says a
//     goal is there (for ClampConfig::confirm_ms without a break), an open clamp closes.
//   - Nothing opens it but a Command's release or the driver: a disabled period keeps the clamp as
//     it is, so a held goal is never dropped by a disable.
//   - In driver control, each press of the clamp button (L1) toggles it. After the driver or the
//     Jetson opens it on a goal, auto close waits until that goal has left the back, or it would
//     re-grab it.
//   - With no sensor fitted (kClampUnknown) the clamp never closes by itself.
//
// Every State reports goal_clamped: 1 while the clamp is closed and the sensor feels a goal, 0
// otherwise, kClampUnknown (255) when no sensor is fitted; and `clamp`, the actuator: open, closed
// or absent.
#pragma once

#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::core {

enum class ClampEvent : uint8_t {
  none,
  auto_closed,
  driver_closed,
  driver_opened,
  jetson_closed,
  jetson_opened,
};

/// For the Log line the robot sends on each event ("clamp closed on a goal", ...).
const char* to_string(ClampEvent e);

class ClampControl {
 public:
  explicit ClampControl(const ClampConfig& config) : config_(config) {}

  /// One loop step. `sensed` is GoalClamp::goal_at_back(); `button` whether the driver holds the
  /// clamp button (read only in driver control); `command` the Jetson's Command.clamp while the
  /// Jetson drives (leave otherwise). Returns what changed; closed() is what to tell the clamp,
  /// goal_clamped() what the State says.
  ClampEvent update(msg::MatchPhase phase, uint8_t sensed, bool button, msg::ClampAction command,
                    uint32_t now_ms);

  bool closed() const { return closed_; }
  uint8_t goal_clamped() const { return goal_clamped_; }

 private:
  ClampConfig config_;
  bool closed_ = false;
  bool armed_ = true;  // auto close may act; false from a driver's release until the goal leaves
  bool goal_seen_ = false;
  uint32_t goal_since_ms_ = 0;
  bool button_was_ = false;
  msg::ClampAction last_command_ = msg::ClampAction::leave;
  uint8_t goal_clamped_ = kClampUnknown;
};

}  // namespace pete::core
