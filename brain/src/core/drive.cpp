#include "pete/core/drive.hpp"

#include <cmath>

namespace pete::core {

namespace {

constexpr double kPi = 3.14159265358979323846;

float clamp(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

}  // namespace

DriveModel::DriveModel(const DriveConfig& config)
    : half_track_m_(config.track_width_m / 2.0f),
      max_wheel_mps_(static_cast<float>(config.cartridge_rpm * config.max_speed_fraction *
                                        config.gear_ratio * kPi * config.wheel_diameter_m / 60.0)),
      mps_to_rpm_(static_cast<float>(60.0 / (kPi * config.wheel_diameter_m * config.gear_ratio))) {}

WheelSpeeds DriveModel::wheels(Twist t) const {
  const float turn = t.angular * half_track_m_;
  return {t.linear + turn, t.linear - turn};
}

Twist DriveModel::twist(WheelSpeeds w) const {
  return {(w.left + w.right) / 2.0f, (w.left - w.right) / (2.0f * half_track_m_)};
}

Twist DriveModel::saturate(Twist t) const {
  if (!std::isfinite(t.linear) || !std::isfinite(t.angular)) return {};
  // In double: a finite float command near FLT_MAX would overflow to inf in float arithmetic.
  const double fastest = std::fabs(static_cast<double>(t.linear)) +
                         std::fabs(static_cast<double>(t.angular)) * half_track_m_;
  if (fastest <= max_wheel_mps_) return t;
  const double scale = max_wheel_mps_ / fastest;
  return {static_cast<float>(t.linear * scale), static_cast<float>(t.angular * scale)};
}

Twist SlewLimiter::step(Twist target, float dt_s) {
  const float dv = max_linear_accel_ * dt_s;
  const float dw = max_angular_accel_ * dt_s;
  current_.linear += clamp(target.linear - current_.linear, -dv, dv);
  current_.angular += clamp(target.angular - current_.angular, -dw, dw);
  return current_;
}

DriveController::DriveController(const DriveConfig& config)
    : model_(config), slew_(config.max_linear_accel, config.max_angular_accel) {}

void DriveController::drive(Twist target, float dt_s, Drivetrain& drivetrain) {
  const Twist limited = model_.saturate(slew_.step(model_.saturate(target), dt_s));
  slew_.reset(limited);
  const WheelSpeeds w = model_.wheels(limited);
  drivetrain.drive_rpm(model_.wheel_to_motor_rpm(w.left), model_.wheel_to_motor_rpm(w.right));
  stopped_ = false;
}

void DriveController::stop(Drivetrain& drivetrain) {
  slew_.reset();
  drivetrain.stop();
  stopped_ = true;
}

}  // namespace pete::core
