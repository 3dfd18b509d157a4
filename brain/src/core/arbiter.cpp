#include "pete/core/arbiter.hpp"

#include <cmath>

namespace pete::core {

namespace {

// Remove the deadband and rescale so that just outside it the output starts from zero.
float shape(float axis, float deadband) {
  if (!std::isfinite(axis)) return 0.0f;
  const float a = axis > 1.0f ? 1.0f : (axis < -1.0f ? -1.0f : axis);
  const float mag = std::fabs(a);
  if (mag <= deadband) return 0.0f;
  const float out = (mag - deadband) / (1.0f - deadband);
  return a < 0.0f ? -out : out;
}

}  // namespace

const char* to_string(DriveSource s) {
  switch (s) {
    case DriveSource::none:
      return "none";
    case DriveSource::jetson:
      return "jetson";
    case DriveSource::driver:
      return "driver";
  }
  return "?";
}

Twist arcade(const DriverSticks& sticks, const DriverConfig& config) {
  if (!sticks.present) return {};
  return {shape(sticks.forward, config.deadband) * config.max_linear_mps,
          shape(sticks.turn, config.deadband) * config.max_angular_rps};
}

bool Arbiter::sticks_active(const DriverSticks& sticks) const {
  if (!sticks.present) return false;
  return sticks.intake || shape(sticks.forward, config_.driver.deadband) != 0.0f ||
         shape(sticks.turn, config_.driver.deadband) != 0.0f;
}

DriveSource Arbiter::decide(msg::MatchPhase phase, bool jetson_live, const DriverSticks& sticks,
                            uint32_t now_ms) {
  switch (phase) {
    case msg::MatchPhase::disabled:
      override_ = false;
      return DriveSource::none;
    case msg::MatchPhase::autonomous:
      override_ = false;
      return jetson_live && config_.jetson_drives_in_autonomous ? DriveSource::jetson
                                                                : DriveSource::none;
    case msg::MatchPhase::driver:
      break;
  }
  if (sticks_active(sticks)) {
    override_ = true;
    last_active_ms_ = now_ms;
  } else if (override_ && now_ms - last_active_ms_ >= config_.driver.override_hold_ms) {
    override_ = false;
  }
  if (override_) return DriveSource::driver;
  if (jetson_live && config_.jetson_drives_in_driver) return DriveSource::jetson;
  return DriveSource::none;
}

}  // namespace pete::core
