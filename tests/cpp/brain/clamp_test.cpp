#include "pete/core/clamp.hpp"
#include "pete/core/lift.hpp"

#include <gtest/gtest.h>

#include <string>

#include "support.hpp"

namespace pete::core {
namespace {

using test::only;
using test::Rig;

constexpr uint32_t kPeriod = kRobotConfig.loop_period_ms;

msg::State last_state(Rig& r) {
  const auto states = only<msg::State>(r.serial.take_messages());
  EXPECT_FALSE(states.empty());
  return states.empty() ? msg::State{} : states.back();
}

bool logged(Rig& r, const std::string& text) {
  bool found = false;
  for (const auto& log : only<msg::Log>(r.serial.take_messages())) found |= text == log.text;
  return found;
}

// A rig with the Jetson connected (so States flow) in `phase`, and a clamp sensor that feels no goal.
Rig& with_sensor(Rig& r, msg::MatchPhase phase) {
  r.sim.competition.set_phase(phase);
  r.sim.clamp.sensor = 0;
  r.handshake();
  r.run(kPeriod);
  return r;
}

TEST(Clamp, ClosesOnAGoalAtTheBackWhileEnabled) {
  for (msg::MatchPhase phase : {msg::MatchPhase::autonomous, msg::MatchPhase::driver}) {
    Rig r;
    with_sensor(r, phase);
    EXPECT_FALSE(r.sim.clamp.closed);
    EXPECT_EQ(last_state(r).goal_clamped, 0u) << "open, sensor fitted: 0";
    r.sim.clamp.sensor = 1;
    r.run(kPeriod);  // closes at the first step that feels the goal
    EXPECT_TRUE(r.sim.clamp.closed);
    EXPECT_TRUE(r.status().clamp_closed);
    r.run(kPeriod);
    EXPECT_TRUE(logged(r, "clamp closed on a goal"));
    r.run(2 * kPeriod);
    EXPECT_EQ(last_state(r).goal_clamped, 1u);
    EXPECT_EQ(r.sim.clamp.changes, 1u);
  }
}

TEST(Clamp, NeverClosesWhileDisabledButClosesOnTheEnable) {
  Rig r;
  with_sensor(r, msg::MatchPhase::disabled);
  r.sim.clamp.sensor = 1;  // a goal pushed against the back before the match
  r.run(50 * kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed);
  EXPECT_EQ(last_state(r).goal_clamped, 0u) << "a goal at an open clamp is not held";
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.run(kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed);
  r.run(kPeriod);
  EXPECT_EQ(last_state(r).goal_clamped, 1u);
}

TEST(Clamp, StaysClosedThroughADisableAndWhateverTheSensorSays) {
  Rig r;
  with_sensor(r, msg::MatchPhase::autonomous);
  r.sim.clamp.sensor = 1;
  r.run(2 * kPeriod);
  ASSERT_TRUE(r.sim.clamp.closed);
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.run(100 * kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "a disable does not drop the goal";
  EXPECT_EQ(last_state(r).goal_clamped, 1u);
  r.sim.competition.set_phase(msg::MatchPhase::driver);
  r.run(10 * kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed);
  r.sim.clamp.sensor = 0;  // the goal was pulled out: closed on nothing
  r.run(10 * kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "nothing but the driver opens it";
  EXPECT_EQ(last_state(r).goal_clamped, 0u) << "closed on nothing holds no goal";
  EXPECT_EQ(r.sim.clamp.changes, 1u);
}

TEST(Clamp, WithoutASensorItSays255AndNeverMoves) {
  Rig r;  // the fake's default, like the PROS adapter as shipped: no sensor
  r.sim.competition.set_phase(msg::MatchPhase::autonomous);
  r.handshake();
  for (msg::MatchPhase phase : {msg::MatchPhase::autonomous, msg::MatchPhase::driver,
                                msg::MatchPhase::disabled}) {
    r.sim.competition.set_phase(phase);
    r.run(20 * kPeriod);
    EXPECT_EQ(last_state(r).goal_clamped, kClampUnknown);
  }
  EXPECT_FALSE(r.sim.clamp.closed);
  EXPECT_EQ(r.sim.clamp.changes, 0u);
}

TEST(Clamp, ConfigurationCanTurnAutoCloseOff) {
  Config c = kRobotConfig;
  c.clamp.auto_close = false;
  Rig r(c);
  with_sensor(r, msg::MatchPhase::autonomous);
  r.sim.clamp.sensor = 1;
  r.run(20 * kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed);
  EXPECT_EQ(last_state(r).goal_clamped, 0u);
}

TEST(Clamp, ConfirmTimeNeedsAnUnbrokenReading) {
  Config c = kRobotConfig;
  c.clamp.confirm_ms = 50;
  Rig r(c);
  with_sensor(r, msg::MatchPhase::autonomous);
  r.sim.clamp.sensor = 1;
  r.run(3 * kPeriod);  // felt for 20 ms
  r.sim.clamp.sensor = 0;  // a glancing touch
  r.run(kPeriod);
  r.sim.clamp.sensor = 1;
  r.run(5 * kPeriod);  // felt at t0 ... t0 + 40
  EXPECT_FALSE(r.sim.clamp.closed);
  r.run(kPeriod);  // t0 + 50
  EXPECT_TRUE(r.sim.clamp.closed);
}

TEST(Clamp, EachPressOfTheDriversButtonTogglesIt) {
  Rig r;
  with_sensor(r, msg::MatchPhase::driver);
  host::FakeDriverInput& pad = r.sim.driver;
  auto press = [&] {
    pad.sticks.clamp = true;
    r.run(5 * kPeriod);  // held for several steps: one toggle
    pad.sticks.clamp = false;
    r.run(kPeriod);
  };
  pad.sticks.present = true;
  press();
  EXPECT_TRUE(r.sim.clamp.closed) << "closed on nothing";
  EXPECT_TRUE(logged(r, "clamp closed by the driver"));
  EXPECT_EQ(r.status().source, DriveSource::none) << "the button alone does not take the drive";
  press();
  EXPECT_FALSE(r.sim.clamp.closed);
  EXPECT_TRUE(logged(r, "clamp opened by the driver"));

  // Auto close grabs a goal; the driver lets it go, and it is not grabbed again at once.
  r.sim.clamp.sensor = 1;
  r.run(kPeriod);
  ASSERT_TRUE(r.sim.clamp.closed);
  press();
  EXPECT_FALSE(r.sim.clamp.closed);
  r.run(20 * kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed) << "the goal the driver released stays released";
  EXPECT_EQ(last_state(r).goal_clamped, 0u);
  r.sim.clamp.sensor = 0;  // it leaves the back; the next goal is grabbed
  r.run(kPeriod);
  r.sim.clamp.sensor = 1;
  r.run(kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed);
}

TEST(Clamp, TheButtonDoesNothingOutsideDriverControl) {
  Rig r;
  with_sensor(r, msg::MatchPhase::autonomous);
  r.sim.driver.sticks.present = true;
  r.sim.driver.sticks.clamp = true;
  r.run(5 * kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed);
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.sim.driver.sticks.clamp = false;
  r.run(kPeriod);
  r.sim.driver.sticks.clamp = true;
  r.run(kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed);
}

// A Command from the Jetson that drives slowly and asks `clamp` and `lift` of the actuators.
std::string actuator_command(uint32_t seq, msg::ClampAction clamp,
                             msg::LiftAction lift = msg::LiftAction::leave) {
  msg::Command c = test::command(seq, 0.1f, 0.0f);
  c.clamp = clamp;
  c.lift = lift;
  return test::downlink(c);
}

TEST(Clamp, TheJetsonHoldsAndReleasesIt) {
  Rig r;
  with_sensor(r, msg::MatchPhase::autonomous);
  EXPECT_EQ(last_state(r).clamp, msg::ClampState::open);
  r.send(actuator_command(1, msg::ClampAction::hold));
  r.run(kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "hold closes it with no goal felt";
  r.run(2 * kPeriod);
  const msg::State held = last_state(r);
  EXPECT_EQ(held.clamp, msg::ClampState::closed);
  EXPECT_EQ(held.goal_clamped, 0u) << "closed on nothing: no goal held";
  r.send(actuator_command(2, msg::ClampAction::leave));
  r.run(5 * kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "leave leaves it closed";

  r.sim.clamp.sensor = 1;  // a goal at the back, then the Jetson lets it go
  r.send(actuator_command(3, msg::ClampAction::release));
  r.run(kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed);
  r.run(kPeriod);
  EXPECT_TRUE(logged(r, "clamp opened by the Jetson"));
  for (uint32_t seq = 4; seq < 14; ++seq) {
    r.send(actuator_command(seq, msg::ClampAction::release));
    r.run(kPeriod);
  }
  EXPECT_FALSE(r.sim.clamp.closed) << "release keeps it open on a goal at the back";
  r.send(actuator_command(20, msg::ClampAction::leave));
  r.run(10 * kPeriod);
  EXPECT_FALSE(r.sim.clamp.closed) << "the goal it let go of is not re-grabbed";
  r.sim.clamp.sensor = 0;
  r.run(kPeriod);
  r.sim.clamp.sensor = 1;
  r.run(kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "the next goal is grabbed by auto close";
}

TEST(Clamp, ReleaseHoldsOffAutoCloseWhileItIsCommanded) {
  Rig r;
  with_sensor(r, msg::MatchPhase::driver);
  uint32_t seq = 1;
  for (int i = 0; i < 5; ++i) {
    r.send(actuator_command(seq++, msg::ClampAction::release));
    r.run(kPeriod);
  }
  r.sim.clamp.sensor = 1;  // a goal arrives while the Jetson says release
  for (int i = 0; i < 10; ++i) {
    r.send(actuator_command(seq++, msg::ClampAction::release));
    r.run(kPeriod);
  }
  EXPECT_FALSE(r.sim.clamp.closed);
}

TEST(Clamp, ADisabledRobotIgnoresTheCommandAndAStaleCommandDoesNothing) {
  Rig r;
  with_sensor(r, msg::MatchPhase::autonomous);
  r.send(actuator_command(1, msg::ClampAction::hold));
  r.run(kPeriod);
  ASSERT_TRUE(r.sim.clamp.closed);
  r.run(400 * kPeriod / 10);  // the Command expires (250 ms): the clamp stays as it is
  EXPECT_TRUE(r.sim.clamp.closed);
  r.sim.competition.set_phase(msg::MatchPhase::disabled);
  r.run(kPeriod);
  r.send(actuator_command(2, msg::ClampAction::release));
  r.run(5 * kPeriod);
  EXPECT_TRUE(r.sim.clamp.closed) << "disabled: nothing moves";
}

TEST(Clamp, WithNoActuatorTheStateSaysAbsent) {
  Rig r;
  r.sim.clamp.actuator = false;
  r.sim.lift.actuator = false;
  with_sensor(r, msg::MatchPhase::autonomous);
  r.run(2 * kPeriod);
  const msg::State s = last_state(r);
  EXPECT_EQ(s.clamp, msg::ClampState::absent);
  EXPECT_EQ(s.lift, msg::LiftState::absent);
}

TEST(Lift, TheJetsonRaisesAndLowersItAndTheDriverToggles) {
  Rig r;
  with_sensor(r, msg::MatchPhase::driver);
  EXPECT_EQ(last_state(r).lift, msg::LiftState::down);
  r.send(actuator_command(1, msg::ClampAction::leave, msg::LiftAction::up));
  r.run(kPeriod);
  EXPECT_TRUE(r.sim.lift.up);
  r.run(2 * kPeriod);
  EXPECT_EQ(last_state(r).lift, msg::LiftState::up);
  r.send(actuator_command(2, msg::ClampAction::leave, msg::LiftAction::leave));
  r.run(3 * kPeriod);
  EXPECT_TRUE(r.sim.lift.up) << "leave leaves it up";
  r.send(actuator_command(3, msg::ClampAction::leave, msg::LiftAction::down));
  r.run(kPeriod);
  EXPECT_FALSE(r.sim.lift.up);
  // The driver's R2 toggles the lift once per press; the Jetson repeating "down" does not undo it.
  r.sim.driver.sticks.present = true;
  r.sim.driver.sticks.lift = true;
  for (uint32_t seq = 4; seq < 9; ++seq) {
    r.send(actuator_command(seq, msg::ClampAction::leave, msg::LiftAction::down));
    r.run(kPeriod);
  }
  EXPECT_TRUE(r.sim.lift.up);
  r.sim.driver.sticks.lift = false;
  r.run(kPeriod);
  r.sim.driver.sticks.lift = true;
  r.run(kPeriod);
  EXPECT_FALSE(r.sim.lift.up);
  EXPECT_EQ(r.sim.lift.changes, 4u);
}

TEST(LiftControl, NothingMovesWhileDisabled) {
  LiftControl l;
  EXPECT_EQ(l.update(msg::MatchPhase::disabled, false, msg::LiftAction::up), LiftEvent::none);
  EXPECT_FALSE(l.up());
  EXPECT_EQ(l.update(msg::MatchPhase::autonomous, true, msg::LiftAction::leave), LiftEvent::none)
      << "the button counts only in driver control";
  EXPECT_EQ(l.update(msg::MatchPhase::autonomous, false, msg::LiftAction::up),
            LiftEvent::jetson_raised);
  EXPECT_EQ(l.update(msg::MatchPhase::disabled, false, msg::LiftAction::down), LiftEvent::none);
  EXPECT_TRUE(l.up());
}

TEST(ClampControl, ReadingsOtherThan0Or1MeanNoSensor) {
  ClampControl c(kRobotConfig.clamp);
  EXPECT_EQ(c.update(msg::MatchPhase::autonomous, 7, false, msg::ClampAction::leave, 0), ClampEvent::none);
  EXPECT_FALSE(c.closed());
  EXPECT_EQ(c.goal_clamped(), kClampUnknown);
  EXPECT_EQ(c.update(msg::MatchPhase::autonomous, 1, false, msg::ClampAction::leave, 10), ClampEvent::auto_closed);
  EXPECT_EQ(c.goal_clamped(), 1u);
  EXPECT_EQ(c.update(msg::MatchPhase::autonomous, kClampUnknown, false, msg::ClampAction::leave, 20), ClampEvent::none);
  EXPECT_TRUE(c.closed()) << "a sensor that stops answering does not open the clamp";
  EXPECT_EQ(c.goal_clamped(), kClampUnknown);
}

}  // namespace
}  // namespace pete::core
