// Link probe for `make firmware-check`: the core on do-nothing hardware, linked for the V5's CPU
// against newlib with no PROS at all. If this links, every symbol the core needs exists on the
// target (no libatomic, no missing libm). It is never run.
#include <cstddef>
#include <cstdint>

#include "pete/core/byte_ring.hpp"
#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/core/robot.hpp"

namespace {

using namespace pete;

volatile float g_sink = 0.0f;

struct Clock final : core::Clock {
  uint32_t ms = 0;
  uint32_t now_ms() const override { return ms; }
  uint64_t now_us() const override { return uint64_t{ms} * 1000u; }
};
struct Gps final : core::PoseSource {
  core::GpsReading read() override { return {}; }
};
struct Imu final : core::Imu {
  core::ImuReading read() override { return {true, 0.0}; }
};
struct Drive final : core::Drivetrain {
  void drive_rpm(float l, float r) override { g_sink = l + r; }
  void stop() override { g_sink = 0.0f; }
  core::WheelFeedback feedback() override { return {}; }
};
struct Intake final : core::Intake {
  void set(bool on) override { g_sink = on ? 1.0f : 0.0f; }
  uint8_t rings_held() override { return core::kRingsUnknown; }
};
struct Clamp final : core::GoalClamp {
  bool fitted() override { return true; }
  void set(bool closed) override { g_sink = closed ? 1.0f : 0.0f; }
  uint8_t goal_at_back() override { return 1; }
};
struct Lift final : core::Lift {
  bool fitted() override { return true; }
  void set(bool up) override { g_sink = up ? 1.0f : 0.0f; }
};
struct Serial final : core::SerialLink {
  core::ByteRing<256> rx;  // as the PROS adapter uses it, so its atomics are linked too
  std::size_t read(uint8_t* buf, std::size_t cap) override { return rx.pop(buf, cap); }
  bool write_packet(const uint8_t*, std::size_t n) override { return n > 0; }
  void write_text(const char*, std::size_t) override {}
};
struct Comp final : core::Competition {
  core::CompetitionStatus read() override { return {}; }
};
struct Sticks final : core::DriverInput {
  core::DriverSticks read() override { return {}; }
};
struct Screen final : core::AllianceInput {
  msg::Alliance read() override { return msg::Alliance::unknown; }
};
struct Radio final : core::Radio {
  bool fitted() override { return false; }
  bool connected() override { return false; }
  bool write(const uint8_t*, std::size_t) override { return false; }
  std::size_t read(uint8_t*, std::size_t) override { return 0; }
};

}  // namespace

int main() {
  static Clock clock;
  static Gps gps;
  static Imu imu;
  static Drive drive;
  static Intake intake;
  static Clamp clamp;
  static Lift lift;
  static Serial serial;
  static Comp comp;
  static Sticks sticks;
  static Screen screen;
  static Radio radio;
  static core::Robot robot(
      core::kRobotConfig,
      core::Hardware{clock, gps, imu, drive, intake, clamp, lift, serial, comp, sticks, screen, radio}, 1u);
  const uint8_t hello[] = ":00\n";
  serial.rx.push(hello, sizeof hello - 1);
  for (uint32_t i = 0; i < 100; ++i) {
    clock.ms = i * core::kRobotConfig.loop_period_ms;
    robot.step();
  }
  return robot.status().steps == 100 ? 0 : 1;
}
