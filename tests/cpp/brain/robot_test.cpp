#include "pete/core/robot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "support.hpp"

namespace pete::core {
namespace {

using test::command;
using test::downlink;
using test::jetson_hello;
using test::only;
using test::Rig;

constexpr uint32_t kPeriod = kRobotConfig.loop_period_ms;

// A rig in autonomous with the Jetson connected, one loop period in.
Rig& connected_in(Rig& r, msg::MatchPhase phase) {
  r.sim.competition.set_phase(phase);
  r.sim.gps.set_pose(0.5, -1.0, 90.0);
  r.handshake();
  return r;
}

msg::State last_state(Rig& r) {
  const auto states = only<msg::State>(r.serial.take_messages());
  EXPECT_FALSE(states.empty());
  return states.empty() ? msg::State{} : states.back();
}

TEST(Robot, ACommandDrivesTheWheelsWithinTheSlewLimit) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  r.send(downlink(command(1, 0.5f, 0.0f, 1000, true)));
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  EXPECT_FALSE(r.motors().stop);
  const DriveModel& m = r.sim.robot.model();
  // First step: at most max_linear_accel * dt.
  EXPECT_NEAR(m.motor_rpm_to_wheel(r.motors().left_rpm),
              kRobotConfig.drive.max_linear_accel * kPeriod / 1000.0f, 1e-4);
  EXPECT_TRUE(r.sim.intake.on);
  // Keep the command alive: the speed ramps up to 0.5 m/s and stays there.
  for (uint32_t seq = 2; seq < 40; ++seq) {
    r.send(downlink(command(seq, 0.5f, 0.0f, 1000, true)));
    r.run(kPeriod);
  }
  EXPECT_NEAR(m.motor_rpm_to_wheel(r.motors().left_rpm), 0.5f, 1e-4);
  EXPECT_NEAR(m.motor_rpm_to_wheel(r.motors().right_rpm), 0.5f, 1e-4);
  EXPECT_EQ(r.status().state.last_command_seq, 39u);  // the State of the last step
}

TEST(Robot, PositiveAngularTurnsClockwise) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  for (uint32_t seq = 1; seq < 30; ++seq) {
    r.send(downlink(command(seq, 0.0f, 1.0f)));
    r.run(kPeriod);
  }
  EXPECT_GT(r.motors().left_rpm, 0.0f);
  EXPECT_LT(r.motors().right_rpm, 0.0f);
  EXPECT_NEAR(r.status().commanded.angular, 1.0f, 1e-4);
}

TEST(Robot, WatchdogStopsTheMotorsWhenTheWindowRunsOut) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);  // now = 10
  r.send(downlink(command(1, 0.4f, 0.0f, 100)));
  r.run(kPeriod);  // step at 10 takes the Command: in force until 110
  ASSERT_EQ(r.status().source, DriveSource::jetson);
  r.run(90);  // steps at 20 ... 100
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  EXPECT_FALSE(r.motors().stop);
  r.serial.take_messages();
  r.run(kPeriod);  // step at 110: 100 ms after it arrived
  EXPECT_EQ(r.status().source, DriveSource::none);
  EXPECT_TRUE(r.motors().stop);
  EXPECT_FALSE(r.sim.intake.on);
  EXPECT_EQ(r.status().command_timeouts, 1u);
  const auto sent = r.serial.take_messages();
  bool logged = false;
  for (const auto& log : only<msg::Log>(sent)) {
    logged |= std::string(log.text).rfind("command timeout", 0) == 0;
  }
  EXPECT_TRUE(logged);
  EXPECT_TRUE(msg::has(r.status().state.faults, msg::Fault::command_timeout));
}

TEST(Robot, ZeroValidityMeansTheDefaultAndLongWindowsAreCut) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  r.send(downlink(command(1, 0.4f, 0.0f, 0)));
  const uint64_t t0 = r.sim.now_ms();
  r.run(kPeriod);
  r.run(kRobotConfig.link.default_command_valid_ms - kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::none);
  EXPECT_EQ(r.sim.now_ms() - t0, kRobotConfig.link.default_command_valid_ms + kPeriod);

  r.send(downlink(command(2, 0.4f, 0.0f, 60000)));
  r.run(kPeriod);
  r.run(kRobotConfig.link.max_command_valid_ms - kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::none) << "a 60 s window is cut to the maximum";
}

TEST(Robot, ARepeatedCommandDoesNotKeepTheRobotAlive) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  const std::string same = downlink(command(7, 0.4f, 0.0f, 100));
  for (int i = 0; i < 30; ++i) {
    r.send(same);
    r.run(kPeriod);
  }
  EXPECT_EQ(r.status().source, DriveSource::none);
  EXPECT_TRUE(r.motors().stop);
}

TEST(Robot, DisabledStopsTheMotorsWhateverArrives) {
  Rig r;
  connected_in(r, msg::MatchPhase::disabled);
  r.sim.driver.sticks = {true, 1.0f, 0.0f, true};
  for (uint32_t seq = 1; seq < 50; ++seq) {
    r.send(downlink(command(seq, 1.0f, 1.0f, 1000, true)));
    r.run(kPeriod);
    ASSERT_TRUE(r.motors().stop) << "step " << seq;
    ASSERT_FALSE(r.sim.intake.on);
    ASSERT_EQ(r.status().source, DriveSource::none);
  }
  // The Commands are still received (the link is healthy), only not applied.
  EXPECT_FALSE(msg::has(r.status().state.faults, msg::Fault::command_timeout));
  EXPECT_EQ(r.status().state.last_command_seq, 0u);
}

TEST(Robot, AReEnableRestartsAutonomousAndNeedsAFreshCommand) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  for (uint32_t seq = 1; seq <= 50; ++seq) {
    r.send(downlink(command(seq, 0.5f, 0.0f, 1000)));
    r.run(kPeriod);
  }
  EXPECT_GE(r.status().phase_ms, 490u);
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.run(kPeriod);
  EXPECT_TRUE(r.motors().stop);
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.run(kPeriod);
  // Command 50 (1 s window) would still be in force, but it arrived in the previous phase.
  EXPECT_EQ(r.status().phase, msg::MatchPhase::autonomous);
  EXPECT_EQ(r.status().phase_ms, 0u);
  EXPECT_TRUE(r.motors().stop);
  r.run(kPeriod);
  EXPECT_EQ(r.status().phase_ms, kPeriod);
  r.send(downlink(command(51, 0.5f, 0.0f, 1000)));
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  EXPECT_FALSE(r.motors().stop);
  EXPECT_NEAR(r.status().commanded.linear, kRobotConfig.drive.max_linear_accel * kPeriod / 1000.0f,
              1e-5)
      << "after a re-enable the robot accelerates from rest";
}

TEST(Robot, FingerprintMismatchKeepsTheRobotStopped) {
  Rig r;
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.send(downlink(jetson_hello(0x0BADF00D)));
  for (uint32_t seq = 1; seq < 60; ++seq) {
    r.send(downlink(command(seq, 1.0f, 0.0f, 1000)));
    r.run(kPeriod);
    ASSERT_TRUE(r.motors().stop);
  }
  r.sim.competition.set_phase(msg::MatchPhase::driver);
  for (uint32_t seq = 60; seq < 80; ++seq) {
    r.send(downlink(command(seq, 1.0f, 0.0f, 1000)));
    r.run(kPeriod);
    ASSERT_TRUE(r.motors().stop);
  }
  const auto sent = r.serial.take_messages();
  EXPECT_TRUE(only<msg::State>(sent).empty()) << "no State to a peer that cannot read it";
  EXPECT_FALSE(only<msg::Hello>(sent).empty());
  bool error_logged = false;
  for (const auto& log : only<msg::Log>(sent)) {
    error_logged |= log.level == msg::LogLevel::error &&
                    std::string(log.text).find("0BADF00D") != std::string::npos;
  }
  EXPECT_TRUE(error_logged);
  EXPECT_TRUE(msg::has(r.status().state.faults, msg::Fault::fingerprint_mismatch));
  EXPECT_EQ(r.sim.robot.link().counters().commands, 0u);
}

TEST(Robot, ReportsGpsStatusAndNeverInventsAPose) {
  Rig r;
  r.sim.gps.set_status(msg::GpsStatus::calibrating);  // no fix yet: no pose at all
  r.handshake();
  r.run(2 * kPeriod);
  msg::State s = last_state(r);
  EXPECT_EQ(s.pose_fix, msg::PoseFix::lost);
  EXPECT_EQ(s.x, 0.0f);
  EXPECT_EQ(s.y, 0.0f);
  EXPECT_EQ(s.heading, 0.0f);
  EXPECT_EQ(s.pose_std, 0.0f);

  r.sim.gps.set_pose(1.25, -0.5, 271.5, 0.02);
  r.run(2 * kPeriod);
  s = last_state(r);
  EXPECT_EQ(s.gps_status, msg::GpsStatus::ok);
  EXPECT_EQ(s.pose_fix, msg::PoseFix::gps);
  EXPECT_NEAR(s.x, 1.25f, 1e-4);
  EXPECT_NEAR(s.y, -0.5f, 1e-4);
  EXPECT_NEAR(s.heading, 271.5f, 1e-3);
  EXPECT_FLOAT_EQ(s.gps_error, 0.02f);
  EXPECT_GT(s.pose_std, 0.0f);
  EXPECT_LE(s.pose_std, 0.02f);
  EXPECT_FALSE(msg::has(s.faults, msg::Fault::gps_fault));

  for (auto status : {msg::GpsStatus::calibrating, msg::GpsStatus::error, msg::GpsStatus::absent}) {
    // The fake holds other numbers: a GPS that is not ok must not leak them into the pose,
    // which now rests on odometry (the robot stands still).
    r.sim.gps.set_pose(-1.0, 1.0, 10.0, 0.02);
    r.sim.gps.set_status(status);
    r.run(30 * kPeriod);
    s = last_state(r);
    EXPECT_EQ(s.gps_status, status);
    EXPECT_EQ(s.gps_error, 0.0f);
    EXPECT_EQ(s.pose_fix, msg::PoseFix::odometry);
    EXPECT_NEAR(s.x, 1.25f, 1e-3);
    EXPECT_NEAR(s.y, -0.5f, 1e-3);
    EXPECT_NEAR(s.heading, 271.5f, 1e-2);
    EXPECT_TRUE(msg::has(s.faults, msg::Fault::gps_fault));
  }
}

TEST(Robot, ThePoseRidesThroughAGpsDropoutOnOdometryAndTheImu) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  r.sim.gps.set_pose(0.5, -1.0, 90.0, 0.013);  // facing +x
  r.sim.imu.set_rotation(0.0);
  r.run(10 * kPeriod);
  r.sim.gps.set_status(msg::GpsStatus::error);  // the strip is blocked
  // The Jetson drives at 0.5 m/s and the wheels report 0.5 m/s on both sides for 2 s: 1 m
  // further along +x (the wheels doing what they are told: no slip).
  r.sim.drive.measured_override = true;
  const float rpm = r.sim.robot.model().wheel_to_motor_rpm(0.5f);
  r.sim.drive.measured.left_rpm = rpm;
  r.sim.drive.measured.right_rpm = rpm;
  for (uint32_t seq = 1; seq <= 200; ++seq) {
    r.send(downlink(command(seq, 0.5f, 0.0f, 1000, false)));
    r.run(kPeriod);
  }
  const msg::State s = last_state(r);
  EXPECT_EQ(s.pose_fix, msg::PoseFix::odometry);
  EXPECT_NEAR(s.x, 1.5f, 0.02);
  EXPECT_NEAR(s.y, -1.0f, 0.02);
  EXPECT_NEAR(s.heading, 90.0f, 0.5);
  EXPECT_GT(s.pose_std, 0.02f) << "the uncertainty grows with the distance driven";
  EXPECT_LT(s.pose_std, 0.2f);
}

TEST(Robot, ImpossibleGpsNumbersAreAnError) {
  GpsReading g{msg::GpsStatus::ok, 0.0, 0.0, 0.0, 0.0};
  auto with = [&](double x, double y, double h, double e) {
    GpsReading r = g;
    r.x_m = x;
    r.y_m = y;
    r.heading_deg = h;
    r.error_m = e;
    return checked_gps(r);
  };
  EXPECT_EQ(with(NAN, 0, 0, 0).status, msg::GpsStatus::error);
  EXPECT_EQ(with(0, INFINITY, 0, 0).status, msg::GpsStatus::error);
  EXPECT_EQ(with(0, 0, 0, NAN).status, msg::GpsStatus::error);
  EXPECT_EQ(with(3.0, 0, 0, 0).status, msg::GpsStatus::error);  // off the field
  EXPECT_EQ(with(0, -9999, 0, 0).status, msg::GpsStatus::error);  // PROS_ERR_F-like
  EXPECT_EQ(with(0, 0, 0, -1).status, msg::GpsStatus::error);
  EXPECT_EQ(with(0, 0, 1e9, 0).status, msg::GpsStatus::error);
  EXPECT_EQ(with(0, 0, 1e9, 0).x_m, 0.0);
  EXPECT_DOUBLE_EQ(with(0, 0, 360.0, 0).heading_deg, 0.0);
  EXPECT_DOUBLE_EQ(with(0, 0, -90.0, 0).heading_deg, 270.0);
  EXPECT_DOUBLE_EQ(with(0, 0, 359.5, 0).heading_deg, 359.5);
  EXPECT_EQ(with(1.8, -1.8, 10, 0.1).status, msg::GpsStatus::ok);
}

TEST(Robot, ArcadeDriveInDriverControlWithoutAJetson) {
  Rig r;
  r.sim.competition.set_phase(msg::MatchPhase::driver);
  r.run(kPeriod);
  EXPECT_TRUE(r.motors().stop) << "no Jetson, sticks centred: stopped";
  r.sim.driver.sticks = {true, 1.0f, 0.0f, true};
  r.run(100 * kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::driver);
  EXPECT_NEAR(r.status().commanded.linear, kRobotConfig.driver.max_linear_mps, 1e-4);
  EXPECT_TRUE(r.sim.intake.on);
  r.sim.driver.sticks = {true, 0.0f, 1.0f, false};  // right stick right: clockwise spin
  r.run(100 * kPeriod);
  EXPECT_GT(r.motors().left_rpm, 0.0f);
  EXPECT_LT(r.motors().right_rpm, 0.0f);
  // Let go: the robot slows under the slew limit for override_hold_ms, then stops.
  r.sim.driver.sticks = {true, 0.0f, 0.0f, false};
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::driver);
  EXPECT_FALSE(r.motors().stop);
  r.run(kRobotConfig.driver.override_hold_ms);
  EXPECT_EQ(r.status().source, DriveSource::none);
  EXPECT_TRUE(r.motors().stop);
}

TEST(Robot, StickDeadbandIgnoresAControllerAtRest) {
  Rig r;
  r.sim.competition.set_phase(msg::MatchPhase::driver);
  r.sim.driver.sticks = {true, kRobotConfig.driver.deadband * 0.9f, -0.02f, false};
  r.run(20 * kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::none);
}

TEST(Robot, TheJetsonDrivesInDriverControlUntilAHumanTakesOver) {
  Rig r;
  connected_in(r, msg::MatchPhase::driver);
  uint32_t seq = 1;
  auto feed = [&](uint32_t ms) {
    for (uint32_t t = 0; t < ms; t += kPeriod) {
      r.send(downlink(command(seq++, 0.3f, 0.0f)));
      r.run(kPeriod);
    }
  };
  feed(100);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  r.sim.driver.sticks = {true, -0.5f, 0.0f, false};
  feed(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::driver) << "a moved stick overrides at once";
  r.sim.driver.sticks = {true, 0.0f, 0.0f, false};
  feed(kRobotConfig.driver.override_hold_ms - kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::driver);
  feed(2 * kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson) << "and hands back after the hold time";
}

TEST(Robot, ConfigurationCanKeepTheJetsonOutOfDriverControl) {
  Config c = kRobotConfig;
  c.jetson_drives_in_driver = false;
  Rig r(c);
  connected_in(r, msg::MatchPhase::driver);
  for (uint32_t seq = 1; seq < 20; ++seq) {
    r.send(downlink(command(seq, 0.3f, 0.0f)));
    r.run(kPeriod);
    ASSERT_NE(r.status().source, DriveSource::jetson);
  }
  EXPECT_TRUE(r.motors().stop);
}

TEST(Robot, TheControllerNeverDrivesInAutonomous) {
  Rig r;
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.sim.driver.sticks = {true, 1.0f, 1.0f, true};
  r.run(30 * kPeriod);
  EXPECT_TRUE(r.motors().stop);
  EXPECT_FALSE(r.sim.intake.on);
}

TEST(Robot, GarbageOnStdinNeverMovesTheRobot) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int step = 0; step < 300; ++step) {
    std::string junk;
    for (int i = 0; i < 64; ++i) junk.push_back(static_cast<char>(byte(rng)));
    r.send(junk);
    r.run(kPeriod);
    ASSERT_TRUE(r.motors().stop) << "step " << step;
  }
  EXPECT_TRUE(msg::has(r.status().state.faults, msg::Fault::link_errors));
}

TEST(Robot, ALateStepRaisesLoopOverrunForASecond) {
  Rig r;
  connected_in(r, msg::MatchPhase::disabled);
  r.run(5 * kPeriod);
  EXPECT_FALSE(msg::has(r.status().state.faults, msg::Fault::loop_overrun));
  // The host skips ahead without stepping: the next step comes 40 ms after the last.
  r.sim.clock.set_ms(r.sim.now_ms());
  const uint64_t late = r.sim.now_ms() + 3 * kPeriod;
  r.sim.clock.set_ms(late);
  r.sim.robot.step();
  EXPECT_TRUE(msg::has(r.status().state.faults, msg::Fault::loop_overrun));
  EXPECT_EQ(r.status().overruns, 1u);
  r.sim.clock.set_ms(late + 1000);
  r.sim.robot.step();
  EXPECT_EQ(r.status().overruns, 2u) << "a 1 s gap is an overrun too";
  for (uint64_t t = late + 1010; t < late + 2100; t += kPeriod) {
    r.sim.clock.set_ms(t);
    r.sim.robot.step();
  }
  EXPECT_FALSE(msg::has(r.status().state.faults, msg::Fault::loop_overrun));
}

TEST(Robot, ReportsMotorFaultsAndMeasuredSpeeds) {
  Rig r;
  connected_in(r, msg::MatchPhase::disabled);
  r.sim.drive.measured_override = true;
  r.sim.drive.measured = {100.0f, -50.0f, true};
  r.run(2 * kPeriod);
  const msg::State s = last_state(r);
  const DriveModel& m = r.sim.robot.model();
  EXPECT_FLOAT_EQ(s.left_speed, m.motor_rpm_to_wheel(100.0f));
  EXPECT_FLOAT_EQ(s.right_speed, m.motor_rpm_to_wheel(-50.0f));
  EXPECT_TRUE(msg::has(s.faults, msg::Fault::motor_fault));
}

TEST(Robot, StateCarriesTheRingCounterOrSaysThereIsNone) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  r.run(2 * kPeriod);
  EXPECT_EQ(last_state(r).rings_held, kRingsUnknown);
  r.sim.intake.rings = 4;
  r.run(2 * kPeriod);
  EXPECT_EQ(last_state(r).rings_held, 4u);
}

TEST(Robot, StateCarriesTimePhaseAndAlliance) {
  Config c = kRobotConfig;
  c.alliance = msg::Alliance::blue;
  Rig r(c);
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.run(100);  // phase begins at the step at t=0
  r.handshake();
  const msg::State s = last_state(r);
  EXPECT_EQ(s.time_ms, 100u);
  EXPECT_EQ(s.phase, msg::MatchPhase::autonomous);
  EXPECT_EQ(s.phase_ms, 100u);
  EXPECT_EQ(s.alliance, msg::Alliance::blue);
  EXPECT_EQ(s.seq, 1u);
}

TEST(Robot, StateCarriesTheMatchPeriodAndItsClock) {
  Rig r;
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.handshake();
  r.run(100);
  msg::State s = last_state(r);
  EXPECT_EQ(s.period, msg::MatchPeriod::before);
  EXPECT_EQ(s.match_ms, 0u);
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.run(10000);
  s = last_state(r);
  EXPECT_EQ(s.period, msg::MatchPeriod::isolation);
  EXPECT_NEAR(static_cast<double>(s.match_ms), static_cast<double>(s.phase_ms), 0.5);
  r.run(6000);
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.run(3000);
  s = last_state(r);
  EXPECT_EQ(s.period, msg::MatchPeriod::pause);
  EXPECT_EQ(s.match_ms, 15000u);
  r.sim.competition.set_phase(msg::MatchPhase::driver);
  r.run(2000);
  s = last_state(r);
  EXPECT_EQ(s.period, msg::MatchPeriod::interaction);
  EXPECT_EQ(s.match_ms, 15000u + s.phase_ms);
  bool logged_period = false;
  r.serial.take_messages();
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.run(103000);
  r.run(50);
  const auto messages = r.serial.take_messages();
  for (const auto& log : only<msg::Log>(messages)) {
    logged_period |= std::string(log.text) == "period after";
  }
  EXPECT_FALSE(logged_period) << "a disable 2 s into interaction is a pause, not the end";
  const auto states = only<msg::State>(messages);
  ASSERT_FALSE(states.empty());
  EXPECT_EQ(states.back().period, msg::MatchPeriod::pause);
  EXPECT_EQ(states.back().match_ms, 17000u);
}

TEST(Robot, PrintsABannerOnStdout) {
  Rig r(kRobotConfig, 0xCAFEF00D);
  r.run(3 * kPeriod);
  EXPECT_EQ(r.serial.text, "pete brain 0.1.0 boot CAFEF00D\n");
  // On the wire it is a PROS `sout` frame, the very first bytes the Brain sends.
  const auto* text = reinterpret_cast<const uint8_t*>(r.serial.text.data());
  const auto frame = host::pros_frame("sout", text, r.serial.text.size());
  ASSERT_GE(r.serial.wire.size(), frame.size());
  EXPECT_TRUE(std::equal(frame.begin(), frame.end(), r.serial.wire.begin()));
}

TEST(Robot, ARestartedJetsonMustSendANewCommand) {
  Rig r;
  connected_in(r, msg::MatchPhase::autonomous);
  r.send(downlink(command(1, 0.5f, 0.0f, 1000)));
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
  r.send(downlink(jetson_hello(msg::kFingerprint, 0xBEEF)));  // same schema, new process
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::none);
  r.send(downlink(command(1, 0.5f, 0.0f, 1000)));  // it numbers from 1 again: accepted
  r.run(kPeriod);
  EXPECT_EQ(r.status().source, DriveSource::jetson);
}

}  // namespace
}  // namespace pete::core
