#include "side_channel.hpp"

#include <gtest/gtest.h>

#include <string>

#include "support.hpp"

namespace pete::host {
namespace {

using test::command;
using test::downlink;
using test::jetson_hello;

/// The serial link for the side channel: the bytes "arrive" when the test says so.
class MemoryIo final : public LinkIo {
 public:
  explicit MemoryIo(MemorySerial& serial) : serial_(serial) {}
  bool wait_rx(uint64_t total, int /*timeout_ms*/) override {
    waited_for = total;
    return rx_total() >= total;
  }
  uint64_t rx_total() const override { return delivered; }
  uint64_t tx_total() const override { return serial_.wire.size(); }
  void deliver(const std::string& bytes) {
    serial_.push_rx(bytes);
    delivered += bytes.size();
  }
  uint64_t delivered = 0;
  uint64_t waited_for = 0;

 private:
  MemorySerial& serial_;
};

struct SideRig {
  explicit SideRig(Mode mode = Mode::lockstep)
      : rig(core::kRobotConfig, serial, 1), io(serial), side(rig, mode, io) {}
  std::string operator()(const std::string& line) { return side.handle(line); }
  MemorySerial serial;
  SimRig rig;
  MemoryIo io;
  SideChannel side;
};

bool has(const std::string& reply, const std::string& part) {
  return reply.find(part) != std::string::npos;
}

TEST(SideChannel, AdvanceRunsTheLoopOnSimulatedTime) {
  SideRig s;
  std::string r = s("advance 100");
  EXPECT_TRUE(has(r, "ok t=100 ")) << r;
  EXPECT_TRUE(has(r, " steps=10 ")) << r;  // steps at 0, 10, ..., 90
  r = s("until 250");
  EXPECT_TRUE(has(r, "ok t=250 ")) << r;
  EXPECT_TRUE(has(r, " steps=25 ")) << r;
  r = s("advance 5");
  EXPECT_TRUE(has(r, " steps=26 ")) << r;  // the step at 250
  r = s("advance 4");
  EXPECT_TRUE(has(r, " steps=26 ")) << r;  // now 259: the next step is at 260
  EXPECT_EQ(s.rig.clock.now_ms(), 259u);
  EXPECT_TRUE(has(s("until 100"), "error time 100 is before now (259)"));
}

TEST(SideChannel, PlaysTheHardwareAndReportsTheWheels) {
  SideRig s;
  EXPECT_EQ(s("phase autonomous"), "ok");
  EXPECT_EQ(s("gps 0.5 -1.25 270 0.02"), "ok");
  s.io.deliver(downlink(jetson_hello()));
  s.io.deliver(downlink(command(1, 0.5f, 0.0f, 1000, true)));
  const std::string want = "rx=" + std::to_string(s.io.delivered);
  std::string r = s("advance 400 " + want);
  EXPECT_EQ(s.io.waited_for, s.io.delivered);
  EXPECT_TRUE(has(r, " phase=autonomous ")) << r;
  EXPECT_TRUE(has(r, " link=connected ")) << r;
  // The command arrived before the first step, whose 1 s window is still open at 390.
  EXPECT_TRUE(has(r, " source=jetson ")) << r;
  EXPECT_TRUE(has(r, " left_mps=0.5 right_mps=0.5 ")) << r;
  EXPECT_TRUE(has(r, " intake=1 ")) << r;
  EXPECT_TRUE(has(r, " gps=ok ")) << r;
  EXPECT_TRUE(has(r, " last_command_seq=1 ")) << r;
  EXPECT_TRUE(has(r, " " + want)) << r;
  r = s("advance 1000");
  EXPECT_TRUE(has(r, " source=none ")) << r;
  EXPECT_TRUE(has(r, " stopped=1 left_rpm=0 right_rpm=0 ")) << r;
  EXPECT_TRUE(has(r, "faults=command_timeout ")) << r;
  EXPECT_EQ(s("gps calibrating"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " gps=calibrating faults=command_timeout,gps_fault ")) << r;
}

TEST(SideChannel, SticksDriveInDriverControl) {
  SideRig s;
  s("phase driver");
  EXPECT_EQ(s("sticks 1 0 intake"), "ok");
  std::string r = s("advance 1000");
  EXPECT_TRUE(has(r, " source=driver ")) << r;
  EXPECT_TRUE(has(r, " intake=1 ")) << r;
  EXPECT_EQ(s("sticks off"), "ok");
  r = s("advance 1000");
  EXPECT_TRUE(has(r, " source=none ")) << r;
}

TEST(SideChannel, MeasuredSpeedsAndMotorFaultsReachTheState) {
  SideRig s;
  EXPECT_EQ(s("measured 0.25 -0.25"), "ok");
  EXPECT_EQ(s("motor_fault 1"), "ok");
  s.io.deliver(downlink(jetson_hello()));
  s("advance 40");
  const msg::State& st = s.rig.robot.status().state;
  EXPECT_NEAR(st.left_speed, 0.25f, 1e-5);
  EXPECT_NEAR(st.right_speed, -0.25f, 1e-5);
  EXPECT_TRUE(msg::has(st.faults, msg::Fault::motor_fault));
  EXPECT_EQ(s("measured auto"), "ok");
  EXPECT_EQ(s("motor_fault 0"), "ok");
  s("advance 20");
  EXPECT_EQ(s.rig.robot.status().state.left_speed, 0.0f);
}

TEST(SideChannel, TheImuAndTheGpsFeedThePoseInTheReport) {
  SideRig s;
  std::string r = s("advance 20");
  EXPECT_TRUE(has(r, " pose=lost ")) << "no GPS reading yet: " << r;
  EXPECT_EQ(s("gps 0.5 -1 90 0.013"), "ok");
  EXPECT_EQ(s("imu 0"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " pose=gps pose_x=0.5 pose_y=-1 pose_heading=90 ")) << r;
  EXPECT_EQ(s("gps error"), "ok");
  EXPECT_EQ(s("measured 0.5 0.5"), "ok");
  EXPECT_EQ(s("imu 0.0"), "ok");
  r = s("advance 1000");
  EXPECT_TRUE(has(r, " pose=odometry pose_x=1 ")) << "0.5 m/s for 1 s along +x: " << r;
  EXPECT_EQ(s("imu off"), "ok");
  EXPECT_EQ(s("imu nan"), "error imu: 'nan' is not a finite number");
  EXPECT_EQ(s("imu"), "error imu ROTATION_DEG | imu off");
  EXPECT_TRUE(has(s("help"), "imu ROTATION_DEG | imu off"));
}

TEST(SideChannel, TheScreenPicksTheAlliance) {
  SideRig s;
  EXPECT_TRUE(has(s("advance 20"), " alliance=unknown")) << "no pick, no GPS fix";
  EXPECT_EQ(s("screen blue"), "ok");
  EXPECT_TRUE(has(s("advance 20"), " alliance=blue"));
  EXPECT_EQ(s("screen none"), "ok");
  EXPECT_EQ(s("gps -1.5 0 90 0.013"), "ok");  // red's half
  EXPECT_TRUE(has(s("advance 20"), " alliance=red"));
  EXPECT_EQ(s("screen green"), "error screen red|blue|none");
}

TEST(SideChannel, ClampSensorAndButtonReachTheStateAndTheReport) {
  SideRig s;
  s.io.deliver(downlink(jetson_hello()));
  std::string r = s("advance 20");
  EXPECT_TRUE(has(r, " clamp=255 clamp_closed=0 ")) << "no sensor by default: " << r;
  EXPECT_EQ(s.rig.robot.status().state.goal_clamped, 255u);
  EXPECT_EQ(s("clamp 0"), "ok");
  EXPECT_EQ(s("phase autonomous"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " clamp=0 clamp_closed=0 ")) << r;
  EXPECT_EQ(s("clamp 1"), "ok");  // a goal touches the back
  r = s("advance 20");
  EXPECT_TRUE(has(r, " clamp=1 clamp_closed=1 ")) << r;
  EXPECT_EQ(s.rig.robot.status().state.goal_clamped, 1u);
  EXPECT_TRUE(s.rig.clamp.closed);
  EXPECT_EQ(s("clamp unknown"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " clamp=255 clamp_closed=1 ")) << r;
  // In driver control the controller's clamp button toggles it.
  EXPECT_EQ(s("clamp 0"), "ok");
  EXPECT_EQ(s("phase driver"), "ok");
  EXPECT_EQ(s("sticks 0 0 clamp"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " clamp=0 clamp_closed=0 ")) << r;
  EXPECT_TRUE(has(r, " source=none ")) << r;
  EXPECT_EQ(s("sticks 0 0 intake clamp"), "ok");
  r = s("advance 20");
  EXPECT_TRUE(has(r, " intake=1 ")) << r;
  EXPECT_TRUE(has(r, " clamp_closed=0 ")) << "still held: no new press " << r;
}

TEST(SideChannel, BadInputGetsAClearErrorAndChangesNothing) {
  SideRig s;
  EXPECT_EQ(s(""), "error empty command (try: help)");
  EXPECT_EQ(s("fly 1"), "error unknown command 'fly' (try: help)");
  EXPECT_EQ(s("gps 1 nan 0"), "error gps: 'nan' is not a finite number");
  EXPECT_EQ(s("gps 1 2"), "error gps X Y HEADING [ERROR] | gps calibrating|error|absent");
  EXPECT_EQ(s("gps lost"), "error gps: 'lost' is not calibrating, error or absent");
  EXPECT_EQ(s("phase halftime"), "error phase: 'halftime' is not disabled, autonomous or driver");
  EXPECT_EQ(s("sticks 2 0"), "error sticks: axes must be in [-1, 1]");
  EXPECT_EQ(s("sticks 0 0 boost"),
            "error sticks: 'boost' should be 'intake', 'clamp' or 'lift', each at most once");
  EXPECT_EQ(s("sticks 0 0 clamp clamp"),
            "error sticks: 'clamp' should be 'intake', 'clamp' or 'lift', each at most once");
  EXPECT_EQ(s("clamp yes"), "error clamp 0|1|unknown");
  EXPECT_EQ(s("clamp"), "error clamp 0|1|unknown");
  EXPECT_EQ(s("advance -5"), "error advance: '-5' is not a whole number of ms");
  EXPECT_EQ(s("advance 10 bytes=3"), "error expected rx=BYTES, got 'bytes=3'");
  EXPECT_EQ(s("advance 10 rx=99"), "error timed out waiting for downlink bytes: have 0, want 99");
  EXPECT_EQ(s("motor_fault yes"), "error motor_fault 0|1");
  EXPECT_EQ(s("advance 99999999999"), "error advance: at most 3600000 ms per command");
  EXPECT_EQ(s("advance 1" + std::string(30, '0')), "error advance: '1" + std::string(30, '0') +
                                                        "' is not a whole number of ms");
  EXPECT_EQ(s.rig.now_ms(), 0u) << "failed commands do not move the clock";
  EXPECT_TRUE(has(s("help"), "advance MS [rx=BYTES]"));
  EXPECT_FALSE(s.side.quit());
  EXPECT_EQ(s("quit"), "ok bye");
  EXPECT_TRUE(s.side.quit());
}

TEST(SideChannel, RealtimeModeRefusesToMoveTheClock) {
  SideRig s(Mode::realtime);
  EXPECT_TRUE(has(s("advance 10"), "error advance/until need --lockstep"));
  EXPECT_TRUE(has(s("get"), "ok t=0 "));
}

}  // namespace
}  // namespace pete::host
