// Differential-drive kinematics: a (forward speed, turn rate) command becomes left/right motor
// speeds, within what the motors can do, without changing the path's curvature, and without
// jerking the robot (acceleration limits).
//
// Sign convention, as in the protocol's Command: `angular` is rad/s, positive CLOCKWISE seen from
// above, so the GPS heading increases; turning clockwise means the left wheels run faster.
#pragma once

#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"

namespace pete::core {

struct Twist {
  float linear = 0.0f;   // m/s, forward positive
  float angular = 0.0f;  // rad/s, clockwise positive
};

/// Wheel surface speeds, m/s, forward positive.
struct WheelSpeeds {
  float left = 0.0f;
  float right = 0.0f;
};

/// Pure geometry of the drive, from DriveConfig.
class DriveModel {
 public:
  explicit DriveModel(const DriveConfig& config);

  WheelSpeeds wheels(Twist t) const;
  Twist twist(WheelSpeeds w) const;
  /// Fastest surface speed either side may be asked for (max_speed_fraction of free speed).
  float max_wheel_speed() const { return max_wheel_mps_; }
  /// `t` scaled down, both components by the same factor, until neither wheel exceeds
  /// max_wheel_speed(): the robot follows the same arc, only slower. Non-finite input gives zero.
  Twist saturate(Twist t) const;
  float wheel_to_motor_rpm(float wheel_mps) const { return wheel_mps * mps_to_rpm_; }
  float motor_rpm_to_wheel(float motor_rpm) const { return motor_rpm / mps_to_rpm_; }

 private:
  float half_track_m_;
  float max_wheel_mps_;
  float mps_to_rpm_;  // motor-shaft rpm per m/s of wheel surface speed
};

/// Limits how fast the commanded twist may change, per component.
class SlewLimiter {
 public:
  SlewLimiter(float max_linear_accel, float max_angular_accel)
      : max_linear_accel_(max_linear_accel), max_angular_accel_(max_angular_accel) {}

  /// Move toward `target` by at most accel * dt_s per component; returns the new command.
  Twist step(Twist target, float dt_s);
  void reset(Twist to = {}) { current_ = to; }
  Twist current() const { return current_; }

 private:
  float max_linear_accel_;
  float max_angular_accel_;
  Twist current_;
};

/// The drive pipeline: saturate the target, slew toward it, saturate again (independent slew of
/// the two components can step outside the motors' range), convert to motor rpm, command.
class DriveController {
 public:
  explicit DriveController(const DriveConfig& config);

  /// Drive toward `target` for one loop step of dt_s seconds.
  void drive(Twist target, float dt_s, Drivetrain& drivetrain);
  /// Failsafe stop: immediate (the motors' brake mode holds), not slewed, and the slew state
  /// restarts from rest so the next drive() accelerates gently.
  void stop(Drivetrain& drivetrain);

  const DriveModel& model() const { return model_; }
  /// The twist most recently sent to the motors (zero after stop()).
  Twist commanded() const { return slew_.current(); }
  bool stopped() const { return stopped_; }

 private:
  DriveModel model_;
  SlewLimiter slew_;
  bool stopped_ = true;
};

}  // namespace pete::core
