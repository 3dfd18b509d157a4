#include "pete/core/drive.hpp"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <random>

#include "fakes.hpp"

namespace pete::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

DriveConfig geometry() {
  DriveConfig c = kRobotConfig.drive;
  c.track_width_m = 0.30f;
  c.wheel_diameter_m = 0.1f;
  c.gear_ratio = 0.75f;
  c.cartridge_rpm = 600.0f;
  c.max_speed_fraction = 1.0f;
  c.max_linear_accel = 2.0f;
  c.max_angular_accel = 10.0f;
  return c;
}

TEST(DriveModel, StraightDriveTurnsBothSidesEqually) {
  const DriveModel m(geometry());
  const WheelSpeeds w = m.wheels({0.8f, 0.0f});
  EXPECT_FLOAT_EQ(w.left, 0.8f);
  EXPECT_FLOAT_EQ(w.right, 0.8f);
}

TEST(DriveModel, ClockwiseTurnRunsTheLeftSideFaster) {
  // Positive angular is clockwise seen from above (the GPS heading increases): the left side is on
  // the outside of the turn.
  const DriveModel m(geometry());
  const WheelSpeeds w = m.wheels({0.5f, 2.0f});
  EXPECT_FLOAT_EQ(w.left, 0.5f + 2.0f * 0.15f);
  EXPECT_FLOAT_EQ(w.right, 0.5f - 2.0f * 0.15f);
  const WheelSpeeds spin = m.wheels({0.0f, -1.0f});
  EXPECT_LT(spin.left, 0.0f);
  EXPECT_GT(spin.right, 0.0f);
}

TEST(DriveModel, TwistIsTheInverseOfWheels) {
  const DriveModel m(geometry());
  const Twist t = m.twist(m.wheels({-0.3f, 1.7f}));
  EXPECT_NEAR(t.linear, -0.3f, 1e-6);
  EXPECT_NEAR(t.angular, 1.7f, 1e-5);
}

TEST(DriveModel, ConvertsWheelSpeedToMotorRpmThroughTheGearRatio) {
  const DriveModel m(geometry());
  // One wheel turn is pi * 0.1 m; the wheel turns 0.75 times per motor turn.
  const double rpm_per_mps = 60.0 / (kPi * 0.1 * 0.75);
  EXPECT_NEAR(m.wheel_to_motor_rpm(1.0f), rpm_per_mps, 1e-3);
  EXPECT_NEAR(m.motor_rpm_to_wheel(600.0f), 600.0 / rpm_per_mps, 1e-5);
  // Free speed of a 600 rpm cartridge through 0.75: 450 wheel rpm.
  EXPECT_NEAR(m.max_wheel_speed(), 450.0 * kPi * 0.1 / 60.0, 1e-5);
}

TEST(DriveModel, MaxSpeedFractionLeavesHeadroom) {
  DriveConfig c = geometry();
  c.max_speed_fraction = 0.5f;
  c.cartridge_rpm = 200.0f;
  const DriveModel m(c);
  EXPECT_NEAR(m.wheel_to_motor_rpm(m.max_wheel_speed()), 100.0f, 1e-3);
}

TEST(DriveModel, SaturationKeepsTheCurvature) {
  const DriveModel m(geometry());
  const Twist in{3.0f, 8.0f};
  const Twist out = m.saturate(in);
  EXPECT_NEAR(out.angular / out.linear, in.angular / in.linear, 1e-5);
  const WheelSpeeds w = m.wheels(out);
  EXPECT_NEAR(std::fmax(std::fabs(w.left), std::fabs(w.right)), m.max_wheel_speed(), 1e-5);
  EXPECT_LT(out.linear, in.linear);
}

TEST(DriveModel, SaturationLeavesFeasibleCommandsAlone) {
  const DriveModel m(geometry());
  const Twist in{0.5f, -1.0f};
  const Twist out = m.saturate(in);
  EXPECT_EQ(out.linear, in.linear);
  EXPECT_EQ(out.angular, in.angular);
}

TEST(DriveModel, SaturationSurvivesExtremeAndNonFiniteInput) {
  const DriveModel m(geometry());
  const Twist huge = m.saturate({FLT_MAX, -FLT_MAX});
  ASSERT_TRUE(std::isfinite(huge.linear) && std::isfinite(huge.angular));
  const WheelSpeeds w = m.wheels(huge);
  EXPECT_LE(std::fabs(w.left), m.max_wheel_speed() * 1.0001f);
  EXPECT_LE(std::fabs(w.right), m.max_wheel_speed() * 1.0001f);
  const Twist nan = m.saturate({std::nanf(""), 1.0f});
  EXPECT_EQ(nan.linear, 0.0f);
  EXPECT_EQ(nan.angular, 0.0f);
  const Twist inf = m.saturate({1.0f, INFINITY});
  EXPECT_EQ(inf.linear, 0.0f);
  EXPECT_EQ(inf.angular, 0.0f);
}

TEST(SlewLimiter, LimitsAccelerationAndDecelerationPerComponent) {
  SlewLimiter s(2.0f, 10.0f);
  const float dt = 0.01f;
  Twist t = s.step({1.0f, -5.0f}, dt);
  EXPECT_NEAR(t.linear, 0.02f, 1e-6);
  EXPECT_NEAR(t.angular, -0.1f, 1e-6);
  for (int i = 0; i < 49; ++i) t = s.step({1.0f, -5.0f}, dt);
  EXPECT_NEAR(t.linear, 1.0f, 1e-4);   // 2 m/s^2 for 0.5 s
  EXPECT_NEAR(t.angular, -5.0f, 1e-4); // 10 rad/s^2 for 0.5 s
  t = s.step({0.0f, 0.0f}, dt);
  EXPECT_NEAR(t.linear, 0.98f, 1e-4);
  EXPECT_NEAR(t.angular, -4.9f, 1e-4);
  // A small change is taken whole.
  s.reset({0.5f, 0.0f});
  t = s.step({0.51f, 0.05f}, dt);
  EXPECT_FLOAT_EQ(t.linear, 0.51f);
  EXPECT_FLOAT_EQ(t.angular, 0.05f);
}

TEST(DriveController, NeverCommandsMoreThanTheMotorsCanDoAndSlewsFeasibleTargets) {
  const DriveConfig c = geometry();
  DriveController dc(c);
  host::FakeDrivetrain motors;
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> any(-20.0f, 20.0f);
  const float max_rpm = c.cartridge_rpm * c.max_speed_fraction;
  const float dt = 0.01f;
  Twist prev = dc.commanded();
  for (int i = 0; i < 5000; ++i) {
    // Half the time an impossible target, half the time a feasible one.
    Twist target{any(rng), any(rng)};
    const bool feasible = i % 2 == 1;
    if (feasible) target = dc.model().saturate({target.linear * 0.02f, target.angular * 0.1f});
    dc.drive(target, dt, motors);
    ASSERT_FALSE(motors.last.stop);
    ASSERT_LE(std::fabs(motors.last.left_rpm), max_rpm * 1.0001f) << "step " << i;
    ASSERT_LE(std::fabs(motors.last.right_rpm), max_rpm * 1.0001f) << "step " << i;
    const Twist now = dc.commanded();
    // Saturation can only shrink a command, so speed changes never exceed the slew limit in
    // magnitude growth; on feasible paths, neither component moves more than accel * dt.
    if (feasible) {
      const WheelSpeeds w = dc.model().wheels(prev);
      const bool prev_inside = std::fabs(w.left) < dc.model().max_wheel_speed() * 0.5f &&
                               std::fabs(w.right) < dc.model().max_wheel_speed() * 0.5f;
      if (prev_inside) {
        ASSERT_LE(std::fabs(now.linear - prev.linear), c.max_linear_accel * dt * 1.001f);
        ASSERT_LE(std::fabs(now.angular - prev.angular), c.max_angular_accel * dt * 1.001f);
      }
    }
    prev = now;
  }
}

TEST(DriveController, StopIsImmediateAndTheNextStartIsGentle) {
  const DriveConfig c = geometry();
  DriveController dc(c);
  host::FakeDrivetrain motors;
  for (int i = 0; i < 100; ++i) dc.drive({1.0f, 0.0f}, 0.01f, motors);
  EXPECT_NEAR(dc.commanded().linear, 1.0f, 1e-4);
  EXPECT_FALSE(dc.stopped());
  dc.stop(motors);
  EXPECT_TRUE(motors.last.stop);
  EXPECT_TRUE(dc.stopped());
  EXPECT_EQ(dc.commanded().linear, 0.0f);
  dc.drive({1.0f, 0.0f}, 0.01f, motors);
  EXPECT_NEAR(dc.model().motor_rpm_to_wheel(motors.last.left_rpm), c.max_linear_accel * 0.01f,
              1e-5);
}

}  // namespace
}  // namespace pete::core
