// The mobile-goal clamp on the robot's back, run the way the simulator's auto clamp behaves
// (sim/world/physics.py, WorldConfig.auto_clamp): nobody commands it in a match.
//
//   - While the robot is enabled (autonomous or driver control) and the sensor at the back says a
//     goal is there (for ClampConfig::confirm_ms without a break), an open clamp closes.
//   - Nothing opens it again: the Jetson has no release command, and a disabled period keeps the
//     clamp as it is, so a held goal is never dropped by a disable.
//   - In driver control, each press of the clamp button (L1) toggles it. After the driver opens
//     it on a goal, auto close waits until that goal has left the back, or it would re-grab it.
//   - With no sensor fitted (kClampUnknown) the clamp never closes by itself.
//
// Every State reports goal_clamped: 1 while the clamp is closed and the sensor feels a goal, 0
// otherwise, kClampUnknown (255) when no sensor is fitted.
#pragma once

#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::core {

enum class ClampEvent : uint8_t { none, auto_closed, driver_closed, driver_opened };

/// For the Log line the robot sends on each event ("clamp closed on a goal", ...).
const char* to_string(ClampEvent e);

class ClampControl {
 public:
  explicit ClampControl(const ClampConfig& config) : config_(config) {}

  /// One loop step. `sensed` is GoalClamp::goal_at_back(); `button` whether the driver holds the
  /// clamp button (read only in driver control). Returns what changed; closed() is what to tell
  /// the clamp, goal_clamped() what the State says.
  ClampEvent update(msg::MatchPhase phase, uint8_t sensed, bool button, uint32_t now_ms);

  bool closed() const { return closed_; }
  uint8_t goal_clamped() const { return goal_clamped_; }

 private:
  ClampConfig config_;
  bool closed_ = false;
  bool armed_ = true;  // auto close may act; false from a driver's release until the goal leaves
  bool goal_seen_ = false;
  uint32_t goal_since_ms_ = 0;
  bool button_was_ = false;
  uint8_t goal_clamped_ = kClampUnknown;
};

}  // namespace pete::core
