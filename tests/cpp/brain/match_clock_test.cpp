#include "pete/core/match_clock.hpp"

#include <gtest/gtest.h>

namespace pete::core {
namespace {

CompetitionStatus status(bool enabled, bool autonomous) {
  CompetitionStatus s;
  s.enabled = enabled;
  s.autonomous = autonomous;
  s.connected = true;
  return s;
}

TEST(MatchClock, PhaseFollowsTheCompetitionBits) {
  EXPECT_EQ(phase_of(status(false, false)), msg::MatchPhase::disabled);
  EXPECT_EQ(phase_of(status(false, true)), msg::MatchPhase::disabled);
  EXPECT_EQ(phase_of(status(true, true)), msg::MatchPhase::autonomous);
  EXPECT_EQ(phase_of(status(true, false)), msg::MatchPhase::driver);
  // No competition switch: PROS reports enabled driver control.
  CompetitionStatus bench;
  bench.enabled = true;
  EXPECT_EQ(phase_of(bench), msg::MatchPhase::driver);
}

TEST(MatchClock, TimesThePhaseFromItsFirstUpdate) {
  MatchClock c;
  EXPECT_EQ(c.phase_ms(5000), 0u);
  EXPECT_TRUE(c.update(status(false, false), 1000));
  EXPECT_EQ(c.phase(), msg::MatchPhase::disabled);
  EXPECT_FALSE(c.update(status(false, false), 1500));
  EXPECT_EQ(c.phase_ms(1500), 500u);
  EXPECT_TRUE(c.update(status(true, true), 2000));
  EXPECT_EQ(c.phase(), msg::MatchPhase::autonomous);
  EXPECT_EQ(c.phase_ms(2000), 0u);
  EXPECT_EQ(c.phase_ms(17000), 15000u);
  EXPECT_TRUE(c.update(status(true, false), 17000));
  EXPECT_EQ(c.phase(), msg::MatchPhase::driver);
  EXPECT_EQ(c.phases_begun(), 3u);
}

TEST(MatchClock, AReEnableRestartsAutonomousFromZero) {
  MatchClock c;
  c.update(status(true, true), 0);
  EXPECT_FALSE(c.update(status(true, true), 4000));
  EXPECT_EQ(c.phase_ms(4000), 4000u);
  EXPECT_TRUE(c.update(status(false, true), 4010));  // field disables the robot
  EXPECT_TRUE(c.update(status(true, true), 9000));   // and enables autonomous again
  EXPECT_EQ(c.phase(), msg::MatchPhase::autonomous);
  EXPECT_EQ(c.phase_ms(9000), 0u);
  EXPECT_EQ(c.phase_ms(9250), 250u);
  EXPECT_EQ(c.phases_begun(), 3u);
}

TEST(MatchClock, SurvivesMillisWrapAround) {
  MatchClock c;
  c.update(status(true, true), 0xFFFFFF00u);
  EXPECT_EQ(c.phase_ms(0x00000100u), 0x200u);
}

}  // namespace
}  // namespace pete::core
