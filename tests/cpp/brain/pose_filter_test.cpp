// The pose filter against a simulated robot: a truth that drives arcs, wheels that slip a few per
// cent, an IMU with a scale error and a drift, and a GPS with VEX's noise and latency.
#include "pete/core/pose_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <limits>
#include <random>

#include "pete/core/config.hpp"

namespace pete::core {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.01;  // the Brain's loop period
constexpr double kTrack = static_cast<double>(kRobotConfig.drive.track_width_m);

struct Truth {
  double x, y, h;  // h: radians clockwise from +y
};

double wrap_deg(double d) {
  d = std::fmod(d, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d < -180.0) d += 360.0;
  return d;
}

/// A robot the filter follows: drive(v, w) moves the truth and feeds the filter odometry and
/// IMU readings with realistic errors; gps() feeds it a noisy reading of the pose 30 ms ago.
class Sim {
 public:
  explicit Sim(PoseFilter& f, uint32_t seed = 7) : f_(f), rng_(seed) {}

  void drive(double v, double w_cw) {
    // Truth: midpoint integration of a unicycle.
    const double hm = t_.h + 0.5 * w_cw * kDt;
    t_.x += v * kDt * std::sin(hm);
    t_.y += v * kDt * std::cos(hm);
    t_.h += w_cw * kDt;
    // Wheels: surface speeds with 3 % more on the left (slip), plus noise.
    const double l = (v + 0.5 * w_cw * kTrack) * 1.03 + noise_(rng_) * 0.01;
    const double r = (v - 0.5 * w_cw * kTrack) + noise_(rng_) * 0.01;
    // IMU: 1 % scale error and a 0.02 deg/s drift.
    imu_deg_ += (w_cw * kDt * 1.01) * 180.0 / kPi + 0.02 * kDt;
    f_.predict(kDt, l, r, true, imu_deg_, kTrack);
    past_.push_back(t_);
    if (past_.size() > 3) past_.pop_front();  // the GPS sees the pose 30 ms ago
    now_ms_ += 10;
  }

  GpsUpdate gps(double dx = 0.0, double dy = 0.0) {
    const Truth& seen = past_.empty() ? t_ : past_.front();
    const double heading = std::fmod(seen.h * 180.0 / kPi + 3600.0, 360.0) + 0.5 * noise_(rng_);
    return f_.correct(seen.x + dx + 0.013 * noise_(rng_), seen.y + dy + 0.013 * noise_(rng_),
                      heading, 0.013, now_ms_);
  }

  /// The first GPS reading, then `steps` control steps driving (v, w) with a reading each: the
  /// filter converged on the GPS.
  void settle(int steps, double v = 0.0, double w_cw = 0.0) {
    gps();
    for (int step = 0; step < steps; ++step) {
      drive(v, w_cw);
      gps();
    }
  }

  double error_m() const { return std::hypot(f_.x() - t_.x, f_.y() - t_.y); }
  double heading_error_deg() const { return std::fabs(wrap_deg(f_.heading_deg() - t_.h * 180.0 / kPi)); }
  uint32_t now_ms() const { return now_ms_; }
  Truth& truth() { return t_; }

 private:
  PoseFilter& f_;
  std::mt19937 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
  Truth t_{0.5, -1.0, kPi / 2};
  std::deque<Truth> past_;
  double imu_deg_ = 0.0;
  uint32_t now_ms_ = 1000;
};

/// A filter anchored by one GPS reading at the field's centre, heading 0 (at time 0).
PoseFilter at_origin() {
  PoseFilter f(kRobotConfig.pose);
  f.correct(0.0, 0.0, 0.0, 0.013, 0);
  return f;
}

TEST(PoseFilter, HasNoPoseUntilTheFirstGpsReading) {
  PoseFilter f(kRobotConfig.pose);
  f.predict(kDt, 1.0, 1.0, true, 0.0, kTrack);
  EXPECT_FALSE(f.initialised());
  EXPECT_EQ(f.fix(0), msg::PoseFix::lost);
  EXPECT_EQ(f.correct(0.3, -0.2, 45.0, 0.02, 100), GpsUpdate::initialised);
  EXPECT_EQ(f.fix(100), msg::PoseFix::gps);
  EXPECT_DOUBLE_EQ(f.x(), 0.3);
  EXPECT_NEAR(f.heading_deg(), 45.0, 1e-9);
  EXPECT_NEAR(f.position_std_m(), 0.02, 1e-9);
}

TEST(PoseFilter, ConvergesOnTheGpsWhileDriving) {
  PoseFilter f(kRobotConfig.pose);
  Sim sim(f);
  ASSERT_EQ(sim.gps(0.05, -0.04), GpsUpdate::initialised);  // a first reading 6 cm off
  double worst = 0.0;
  double sum_sq = 0.0;
  for (int step = 0; step < 500; ++step) {  // 5 s of arcs at 0.8 m/s
    sim.drive(0.8, step < 250 ? 1.0 : -0.6);
    if (step % 2 == 0) {
      EXPECT_NE(sim.gps(), GpsUpdate::rejected) << "step " << step;
    }
    if (step >= 100) {
      worst = std::max(worst, sim.error_m());
      sum_sq += sim.error_m() * sim.error_m();
    }
  }
  EXPECT_LT(std::sqrt(sum_sq / 400.0), 0.015) << "RMS error once converged (GPS noise 13 mm)";
  EXPECT_LT(worst, 0.04);
  EXPECT_LT(sim.heading_error_deg(), 2.0);
  EXPECT_LT(f.position_std_m(), 0.02);
  EXPECT_EQ(f.fix(sim.now_ms()), msg::PoseFix::gps);
  EXPECT_EQ(f.rejected(), 0u);
}

TEST(PoseFilter, RidesThroughAThreeSecondDropoutWithinABound) {
  PoseFilter f(kRobotConfig.pose);
  Sim sim(f, 11);
  sim.settle(200, 0.8, 0.5);
  ASSERT_LT(sim.error_m(), 0.03);
  const double std_before = f.position_std_m();
  double worst = 0.0;
  for (int step = 0; step < 300; ++step) {  // 3 s with the strip out of sight: 2.4 m driven
    sim.drive(1.0 - 0.2 * (step / 150), step < 150 ? 0.8 : -0.8);
    worst = std::max(worst, sim.error_m());
    EXPECT_LE(sim.error_m(), 3.0 * f.position_std_m() + 0.02)
        << "the error stays inside the reported uncertainty, step " << step;
  }
  EXPECT_EQ(f.fix(sim.now_ms()), msg::PoseFix::odometry);
  EXPECT_LT(worst, 0.15) << "dead reckoning drifts less than 15 cm in 3 s";
  EXPECT_LT(sim.heading_error_deg(), 3.0);
  EXPECT_GT(f.position_std_m(), 2.0 * std_before) << "and says it trusts the pose less";
  EXPECT_LT(f.position_std_m(), 0.3);
  // The strip comes back: back to GPS accuracy within half a second.
  for (int step = 0; step < 50; ++step) {
    sim.drive(0.6, 0.0);
    EXPECT_NE(sim.gps(), GpsUpdate::rejected) << "the returning GPS is believed, step " << step;
  }
  EXPECT_LT(sim.error_m(), 0.03);
  EXPECT_EQ(f.fix(sim.now_ms()), msg::PoseFix::gps);
}

TEST(PoseFilter, RejectsAGpsJumpAndReanchorsWhenItPersists) {
  PoseFilter f(kRobotConfig.pose);
  Sim sim(f, 3);
  sim.settle(100);
  const double x0 = f.x();
  const double y0 = f.y();
  for (int step = 0; step < 40; ++step) {  // 400 ms of readings 0.6 m off (a reflection, say)
    sim.drive(0.0, 0.0);
    EXPECT_EQ(sim.gps(0.6, 0.0), GpsUpdate::rejected);
  }
  EXPECT_LT(std::hypot(f.x() - x0, f.y() - y0), 0.01) << "a jump does not move the pose";
  EXPECT_EQ(f.fix(sim.now_ms()), msg::PoseFix::odometry) << "rejected readings are not a fix";
  for (int step = 0; step < 20; ++step) {
    sim.drive(0.0, 0.0);
    sim.gps();
  }
  EXPECT_LT(sim.error_m(), 0.02);
  // The robot was really moved (pushed sideways, picked up): the first readings are rejected,
  // the pose's uncertainty grows while they disagree, and within reanchor_ms the GPS wins.
  sim.truth().x += 0.8;
  const uint32_t rejected_before = f.rejected();
  int steps = 0;
  for (; steps < 120 && sim.error_m() > 0.05; ++steps) {
    sim.drive(0.0, 0.0);
    sim.gps();
  }
  EXPECT_LT(sim.error_m(), 0.05);
  EXPECT_LE(steps, 105) << "followed within a second (and the GPS's 30 ms)";
  EXPECT_GT(steps, 40) << "but not at once: a glitch of 400 ms is not believed";
  EXPECT_GT(f.rejected() - rejected_before, 35u);
}

TEST(PoseFilter, RejectionsWidenTheUncertaintyAndASidewaysPushIsFollowedQuickly) {
  PoseFilter f(kRobotConfig.pose);
  Sim sim(f, 5);
  sim.settle(100);
  const double std0 = f.position_std_m();
  sim.truth().y += 0.15;  // shoved 15 cm sideways by another robot, wheels still
  int steps = 0;
  double std_max = std0;
  for (; steps < 100 && sim.error_m() > 0.03; ++steps) {
    sim.drive(0.0, 0.0);
    sim.gps();
    std_max = std::max(std_max, f.position_std_m());
  }
  EXPECT_LT(sim.error_m(), 0.03);
  EXPECT_LE(steps, 30) << "a 15-cm push is followed within 0.3 s";
  EXPECT_GT(std_max, 2.0 * std0) << "and the pose said it was less sure meanwhile";
  EXPECT_EQ(f.reanchors(), 0u);
}

TEST(PoseFilter, AfterADropoutThePoseFollowsAGpsThatDisagreesWithinAFewReadings) {
  // Three seconds with the strip hidden, standing against another robot that shoves this one
  // 0.5 m sideways; its wheels and the IMU see nothing. When the strip comes back the readings
  // disagree with the pose by 0.5 m: it follows them within a few readings, not after the
  // second of rejections a glitch would need, and never says lost meanwhile.
  PoseFilter f(kRobotConfig.pose);
  Sim sim(f, 9);
  sim.settle(100);
  for (int step = 0; step < 300; ++step) {
    sim.drive(0.0, 0.0);
    if (step >= 100 && step < 200) sim.truth().x += 0.005;  // 0.5 m in a second, unseen
  }
  ASSERT_GT(sim.error_m(), 0.45);
  int steps = 0;
  for (; steps < 100 && sim.error_m() > 0.03; ++steps) {
    sim.drive(0.0, 0.0);
    sim.gps();
    EXPECT_NE(f.fix(sim.now_ms()), msg::PoseFix::lost) << "step " << steps;
  }
  EXPECT_LT(sim.error_m(), 0.03);
  EXPECT_LE(steps, 5) << "followed within a few readings";
  EXPECT_EQ(f.reanchors(), 0u);
}

TEST(PoseFilter, HeadingWrapsAroundNorth) {
  PoseFilter f(kRobotConfig.pose);
  f.correct(0.0, 0.0, 359.5, 0.013, 0);
  double imu = 0.0;
  for (int i = 0; i < 100; ++i) {  // turn 1 degree clockwise over a second
    imu += 0.01;
    f.predict(kDt, 0.0, 0.0, true, imu, kTrack);
    EXPECT_NE(f.correct(0.0, 0.0, std::fmod(359.5 + imu, 360.0), 0.013, 10u * static_cast<uint32_t>(i)),
              GpsUpdate::rejected);
  }
  EXPECT_NEAR(wrap_deg(f.heading_deg() - 0.5), 0.0, 0.2);
  EXPECT_GE(f.heading_deg(), 0.0);
  EXPECT_LT(f.heading_deg(), 360.0);
}

TEST(PoseFilter, BadNumbersAreIgnoredNeverStored) {
  PoseFilter f(kRobotConfig.pose);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(f.correct(nan, 0.0, 0.0, 0.01, 0), GpsUpdate::none);
  EXPECT_EQ(f.correct(0.0, 0.0, inf, 0.01, 0), GpsUpdate::none);
  EXPECT_EQ(f.correct(0.0, 0.0, 0.0, -1.0, 0), GpsUpdate::none);
  EXPECT_EQ(f.correct(0.0, 0.0, 0.0, 5.0, 0), GpsUpdate::none) << "its own error too large";
  EXPECT_FALSE(f.initialised());
  f.correct(0.2, 0.1, 10.0, 0.013, 0);
  f.predict(kDt, nan, inf, true, nan, kTrack);
  f.predict(nan, 1.0, 1.0, false, 0.0, kTrack);
  f.predict(kDt, 1.0, 1.0, true, 1e9, kTrack);  // an IMU that jumps is not believed
  EXPECT_TRUE(std::isfinite(f.x()) && std::isfinite(f.y()) && std::isfinite(f.heading_deg()));
  EXPECT_TRUE(std::isfinite(f.position_std_m()) && std::isfinite(f.heading_std_deg()));
  EXPECT_NEAR(f.heading_deg(), 10.0, 1.0);
}

TEST(PoseFilter, WithoutAnImuTheWheelsTurnItAndTrustGrowsFaster) {
  PoseFilter with = at_origin();
  PoseFilter without = at_origin();
  double imu = 0.0;
  for (int i = 0; i < 100; ++i) {  // a spin on the spot, clockwise, 1 rad/s for 1 s
    const double v = 0.5 * kTrack;
    imu += 180.0 / kPi * kDt;
    with.predict(kDt, v, -v, true, imu, kTrack);
    without.predict(kDt, v, -v, false, 0.0, kTrack);
  }
  EXPECT_NEAR(with.heading_deg(), 180.0 / kPi, 0.01);
  EXPECT_NEAR(without.heading_deg(), 180.0 / kPi, 0.01);
  EXPECT_GT(without.heading_std_deg(), 2.0 * with.heading_std_deg());
}

TEST(PoseFilter, SlipThroughADropoutWidensTheTrustToCoverTheError) {
  // Pushing a goal across the field with the strip hidden: the motors are told 0.8 m/s, the
  // wheels measure 0.3 m/s (spinning), and the robot is shoved 0.4 m sideways in 2 s, which its
  // wheels never see. Without the told speeds the filter is sure to centimetres; with them it
  // says it is not, and its error stays inside three of its standard deviations.
  PoseFilter told = at_origin();
  PoseFilter blind = at_origin();
  double tx = 0.0;
  double ty = 0.0;
  for (int step = 0; step < 200; ++step) {
    ty += 0.3 * kDt;
    tx += 0.2 * kDt;  // sideways (+x while heading +y), unseen
    told.commanded(0.8, 0.8);
    told.predict(kDt, 0.3, 0.3, true, 0.0, kTrack);
    blind.predict(kDt, 0.3, 0.3, true, 0.0, kTrack);
    const double err = std::hypot(told.x() - tx, told.y() - ty);
    EXPECT_LE(err, 3.0 * told.position_std_m()) << "step " << step;
  }
  EXPECT_GT(told.slip_m(), 0.65) << "0.4 m/s beyond the deadband for 2 s";
  EXPECT_LT(blind.position_std_m(), 0.06) << "odometry alone cannot see the slip";
  EXPECT_GT(told.position_std_m(), 3.0 * blind.position_std_m());
  EXPECT_GT(std::hypot(blind.x() - tx, blind.y() - ty), 3.0 * blind.position_std_m())
      << "the blind filter is overconfident: the case this guards against";
  // The strip comes back: the first reading is believed and the pose snaps to it.
  EXPECT_EQ(told.correct(tx, ty, 0.0, 0.013, 2000), GpsUpdate::accepted);
  EXPECT_LT(std::hypot(told.x() - tx, told.y() - ty), 0.03);
}

TEST(PoseFilter, DrivingAsToldDoesNotWidenTheTrust) {
  // Normal driving: the measured speeds trail the told ones by the motors' lag (under the
  // deadband) and noise. The trust grows as it does without the told speeds.
  PoseFilter told = at_origin();
  PoseFilter plain = at_origin();
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.01);
  double imu = 0.0;
  for (int step = 0; step < 300; ++step) {
    const double v = step < 100 ? 0.012 * step : 1.2;  // accelerating, then cruising
    const double w = step < 150 ? 0.5 : -0.5;
    const double l = v + 0.5 * w * kTrack;
    const double r = v - 0.5 * w * kTrack;
    imu += w * kDt * 180.0 / kPi;
    const double ml = l - 0.06 + noise(rng);
    const double mr = r - 0.06 + noise(rng);
    told.commanded(l, r);
    told.predict(kDt, ml, mr, true, imu, kTrack);
    plain.predict(kDt, ml, mr, true, imu, kTrack);
  }
  EXPECT_LT(told.slip_m(), 0.01);
  EXPECT_NEAR(told.position_std_m(), plain.position_std_m(), 0.002);
}

TEST(PoseFilter, WheelsTurningWhereTheImuDoesNotIsSlip) {
  // One side's wheels spin (0.9 m/s against 0.1 m/s) while the IMU says the robot goes straight.
  PoseFilter f = at_origin();
  PoseFilter g = at_origin();
  f.predict(kDt, 0.0, 0.0, true, 0.0, kTrack);  // the IMU's first reading: the reference
  g.predict(kDt, 0.0, 0.0, true, 0.0, kTrack);
  for (int step = 0; step < 100; ++step) {
    f.predict(kDt, 0.9, 0.1, true, 0.0, kTrack);
    g.predict(kDt, 0.5, 0.5, true, 0.0, kTrack);
  }
  EXPECT_NEAR(f.heading_deg(), 0.0, 1e-9) << "the IMU's heading, not the wheels'";
  EXPECT_GT(f.slip_m(), 0.2) << "0.3 m/s beyond the deadband for 1 s";
  EXPECT_GT(f.position_std_m(), 2.0 * g.position_std_m());
}

}  // namespace
}  // namespace pete::core
