#include "pete/core/alliance.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "pete/core/config.hpp"
#include "support.hpp"

namespace pete::core {
namespace {

using test::only;
using test::Rig;

constexpr AllianceConfig kFind = kRobotConfig.find_alliance;
constexpr auto kBefore = msg::MatchPeriod::before;
constexpr auto kIsolation = msg::MatchPeriod::isolation;
constexpr auto kUnknown = msg::Alliance::unknown;

TEST(AllianceFinder, TheGpsStartPoseSaysWhichHalf) {
  AllianceFinder f(kFind, kUnknown);
  EXPECT_EQ(f.alliance(), kUnknown);
  EXPECT_FALSE(f.update(kUnknown, kBefore, 0, false, -1.5)) << "no GPS fix: nothing to say";
  EXPECT_TRUE(f.update(kUnknown, kBefore, 0, true, -1.5));
  EXPECT_EQ(f.alliance(), msg::Alliance::red) << "red's half is x < 0";
  EXPECT_EQ(f.source(), AllianceSource::gps);
  EXPECT_TRUE(f.update(kUnknown, kBefore, 0, true, 1.2));  // carried to the other side
  EXPECT_EQ(f.alliance(), msg::Alliance::blue);
  AllianceFinder centre(kFind, kUnknown);
  centre.update(kUnknown, kBefore, 0, true, 0.1);
  EXPECT_EQ(centre.alliance(), kUnknown) << "too close to the centre line to tell";
}

TEST(AllianceFinder, LocksOnceTheMatchHasRunASecondAndLooksAgainAfterIt) {
  AllianceFinder f(kFind, kUnknown);
  f.update(kUnknown, kBefore, 0, true, -1.5);
  f.update(kUnknown, kIsolation, 500, true, -1.4);
  EXPECT_EQ(f.alliance(), msg::Alliance::red);
  f.update(kUnknown, kIsolation, 1500, true, 1.0);  // crossed into blue's half in the match
  EXPECT_EQ(f.alliance(), msg::Alliance::red);
  f.update(kUnknown, msg::MatchPeriod::pause, 15000, true, 1.0);
  f.update(kUnknown, msg::MatchPeriod::interaction, 16000, true, 1.0);
  EXPECT_EQ(f.alliance(), msg::Alliance::red) << "the pause is the same match";
  f.update(kUnknown, msg::MatchPeriod::after, 120000, true, 1.4);  // the next match's start
  EXPECT_EQ(f.alliance(), msg::Alliance::blue);
}

TEST(AllianceFinder, AScreenPickWinsAndAFixedConfigComesNext) {
  AllianceFinder f(kFind, kUnknown);
  f.update(msg::Alliance::blue, kBefore, 0, true, -1.5);
  EXPECT_EQ(f.alliance(), msg::Alliance::blue);
  EXPECT_EQ(f.source(), AllianceSource::screen);
  f.update(msg::Alliance::blue, kIsolation, 5000, true, -1.5);
  EXPECT_EQ(f.alliance(), msg::Alliance::blue);
  f.update(kUnknown, kBefore, 0, false, 0.0);  // the pick withdrawn, no GPS yet
  EXPECT_EQ(f.alliance(), kUnknown);
  AllianceFinder fixed(kFind, msg::Alliance::red);
  fixed.update(kUnknown, kBefore, 0, true, 1.5);
  EXPECT_EQ(fixed.alliance(), msg::Alliance::red);
  EXPECT_EQ(fixed.source(), AllianceSource::config);
  fixed.update(msg::Alliance::blue, kBefore, 0, true, 1.5);
  EXPECT_EQ(fixed.alliance(), msg::Alliance::blue) << "the screen wins over the configuration";
}

TEST(AllianceFinder, BadNumbersSayNothing) {
  AllianceFinder f(kFind, kUnknown);
  f.update(kUnknown, kBefore, 0, true, std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(f.alliance(), kUnknown);
}

TEST(Robot, TheAllianceIsFoundFromTheGpsStartPoseAndLogged) {
  Rig r;  // kRobotConfig: alliance unknown, found at run time
  r.sim.gps.set_pose(1.55, -1.37, 270.0);  // blue's corner
  r.handshake();
  r.run(100);
  bool logged = false;
  msg::State last{};
  for (const auto& m : r.serial.take_messages()) {
    if (m.id == msg::Log::kId) {
      logged |= std::string(m.log.text) == "alliance blue from the GPS start pose";
    }
    if (m.id == msg::State::kId) last = m.state;
  }
  EXPECT_TRUE(logged);
  EXPECT_EQ(last.alliance, msg::Alliance::blue);
  r.sim.screen.pick = msg::Alliance::red;  // the driver picks red on the screen
  r.run(40);
  const auto states = only<msg::State>(r.serial.take_messages());
  ASSERT_FALSE(states.empty());
  EXPECT_EQ(states.back().alliance, msg::Alliance::red);
}

TEST(Robot, WithNeitherAPickNorAGpsFixTheAllianceIsUnknown) {
  Rig r;
  r.sim.gps.set_status(msg::GpsStatus::calibrating);
  r.handshake();
  r.run(100);
  const auto states = only<msg::State>(r.serial.take_messages());
  ASSERT_FALSE(states.empty());
  EXPECT_EQ(states.back().alliance, msg::Alliance::unknown);
}

}  // namespace
}  // namespace pete::core
