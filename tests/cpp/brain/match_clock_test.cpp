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

TEST(MatchClock, AVexAiMatchIsIsolationPauseInteraction) {
  MatchClock c;  // 15 s + 105 s
  c.update(status(false, false), 0);
  EXPECT_EQ(c.period(), msg::MatchPeriod::before);
  EXPECT_EQ(c.match_ms(5000), 0u);
  c.update(status(true, true), 10000);  // isolation
  EXPECT_EQ(c.period(), msg::MatchPeriod::isolation);
  EXPECT_TRUE(c.match_began());
  EXPECT_EQ(c.matches_begun(), 1u);
  EXPECT_EQ(c.match_ms(14000), 4000u);
  EXPECT_EQ(c.match_ms(26000), 15000u) << "isolation's clock stops at 15 s";
  c.update(status(false, true), 25000);  // the disable between the periods
  EXPECT_EQ(c.period(), msg::MatchPeriod::pause);
  EXPECT_FALSE(c.match_began());
  EXPECT_EQ(c.match_ms(30000), 15000u);
  c.update(status(true, false), 32000);  // interaction
  EXPECT_EQ(c.period(), msg::MatchPeriod::interaction);
  EXPECT_FALSE(c.match_began()) << "the same match goes on";
  EXPECT_EQ(c.matches_begun(), 1u);
  EXPECT_EQ(c.match_ms(32000), 15000u);
  EXPECT_EQ(c.match_ms(92000), 75000u);
  EXPECT_EQ(c.match_ms(200000), 120000u) << "capped at the match's end";
  c.update(status(false, false), 137000);  // 105 s later: the end
  EXPECT_EQ(c.period(), msg::MatchPeriod::after);
  EXPECT_EQ(c.match_ms(150000), 120000u);
  c.update(status(true, true), 300000);  // the next match
  EXPECT_EQ(c.period(), msg::MatchPeriod::isolation);
  EXPECT_TRUE(c.match_began());
  EXPECT_EQ(c.matches_begun(), 2u);
  EXPECT_EQ(c.match_ms(301000), 1000u);
}

TEST(MatchClock, AnEarlyDisableInInteractionIsAPauseOfTheSameMatch) {
  MatchClock c;
  c.update(status(true, true), 0);
  c.update(status(true, false), 15000);  // straight into interaction, no disable between
  EXPECT_EQ(c.period(), msg::MatchPeriod::interaction);
  EXPECT_EQ(c.matches_begun(), 1u);
  c.update(status(false, false), 45000);  // a field fault 30 s in
  EXPECT_EQ(c.period(), msg::MatchPeriod::pause);
  EXPECT_EQ(c.match_ms(50000), 45000u);
  c.update(status(true, false), 60000);
  EXPECT_EQ(c.period(), msg::MatchPeriod::interaction);
  EXPECT_FALSE(c.match_began());
  EXPECT_EQ(c.match_ms(61000), 46000u) << "the interaction clock goes on from 30 s";
  c.update(status(false, false), 60000 + 74000);  // 104 s of interaction in all: within the slack
  EXPECT_EQ(c.period(), msg::MatchPeriod::after);
}

TEST(MatchClock, DriverControlWithoutIsolationIsAMatchOfItsOwn) {
  MatchClock c;
  c.update(status(true, false), 0);  // no competition switch: PROS says enabled driver control
  EXPECT_EQ(c.period(), msg::MatchPeriod::interaction);
  EXPECT_TRUE(c.match_began());
  EXPECT_EQ(c.match_ms(1000), 16000u);
  c.update(status(true, true), 5000);  // autonomous from interaction: a new match
  EXPECT_TRUE(c.match_began());
  EXPECT_EQ(c.matches_begun(), 2u);
  c.update(status(false, true), 6000);
  c.update(status(true, true), 7000);  // re-enabled in isolation: the same match
  EXPECT_FALSE(c.match_began());
  EXPECT_EQ(c.period(), msg::MatchPeriod::isolation);
  EXPECT_EQ(c.matches_begun(), 2u);
}

TEST(MatchClock, SurvivesMillisWrapAround) {
  MatchClock c;
  c.update(status(true, true), 0xFFFFFF00u);
  EXPECT_EQ(c.phase_ms(0x00000100u), 0x200u);
}

}  // namespace
}  // namespace pete::core
