// Who drives the robot this loop step: nobody, the Jetson, or the driver with the V5 controller.
//
// The rule (brain/README.md repeats it for drive teams):
//   disabled    nobody, whatever arrives.
//   autonomous  the Jetson while its link is live (handshake done, a Command in force) and the
//               configuration lets it drive in autonomous; otherwise nobody. The controller never
//               drives in autonomous (VEX rules).
//   driver      the driver (arcade drive) while they are moving a stick or holding the intake
//               button, and for override_hold_ms after they let go, so the robot slows down
//               smoothly: a human can always take over. Otherwise the Jetson while its link is
//               live and the configuration lets it drive in driver control; otherwise nobody.
// "Nobody" means the motors are stopped at once (brake mode), not slewed down.
#pragma once

#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/core/drive.hpp"
#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::core {

enum class DriveSource : uint8_t { none, jetson, driver };

const char* to_string(DriveSource s);

/// Arcade mix of the sticks: forward -> linear speed, turn -> clockwise turn rate, each with the
/// deadband removed and rescaled so the output is continuous at its edge.
Twist arcade(const DriverSticks& sticks, const DriverConfig& config);

class Arbiter {
 public:
  explicit Arbiter(const Config& config) : config_(config) {}

  DriveSource decide(msg::MatchPhase phase, bool jetson_live, const DriverSticks& sticks,
                     uint32_t now_ms);
  /// Drop any driver override (on a phase change).
  void reset() { override_ = false; }
  bool overriding() const { return override_; }

 private:
  bool sticks_active(const DriverSticks& sticks) const;

  Config config_;
  bool override_ = false;
  uint32_t last_active_ms_ = 0;
};

}  // namespace pete::core
