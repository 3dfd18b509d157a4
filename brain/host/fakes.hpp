// Host stand-ins for the Brain's hardware: a clock the caller sets, motors and a goal clamp that
// record what they were told, a GPS, a clamp sensor and a competition switch the caller controls,
// and an in-memory serial link that keeps the exact bytes PROS would put on the USB wire. Host-only code: it may allocate.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "pete/core/hal.hpp"
#include "pete/messages.hpp"

namespace pete::host {

class FakeClock final : public core::Clock {
 public:
  uint32_t now_ms() const override { return static_cast<uint32_t>(us_ / 1000); }
  uint64_t now_us() const override { return us_; }
  void set_ms(uint64_t ms) { us_ = ms * 1000; }
  void advance_ms(uint64_t ms) { us_ += ms * 1000; }
  void set_us(uint64_t us) { us_ = us; }

 private:
  uint64_t us_ = 0;
};

class FakeGps final : public core::PoseSource {
 public:
  core::GpsReading read() override {
    ++reads;
    return reading;
  }
  void set_pose(double x, double y, double heading, double error = 0.01) {
    reading = {msg::GpsStatus::ok, x, y, heading, error};
  }
  void set_status(msg::GpsStatus status) { reading.status = status; }

  core::GpsReading reading;
  uint32_t reads = 0;
};

/// The inertial sensor: reads what the caller sets (not fitted until told otherwise).
class FakeImu final : public core::Imu {
 public:
  core::ImuReading read() override { return reading; }
  void set_rotation(double deg) { reading = {true, deg}; }
  core::ImuReading reading;
};

/// One thing the drivetrain was told.
struct DriveCall {
  bool stop = false;
  float left_rpm = 0.0f;
  float right_rpm = 0.0f;
};

class FakeDrivetrain final : public core::Drivetrain {
 public:
  void drive_rpm(float left_rpm, float right_rpm) override {
    record({false, left_rpm, right_rpm});
  }
  void stop() override { record({true, 0.0f, 0.0f}); }
  /// An ideal motor unless told otherwise: it turns at the speed it was last told.
  core::WheelFeedback feedback() override {
    if (measured_override) return measured;
    core::WheelFeedback fb;
    fb.left_rpm = last.left_rpm;
    fb.right_rpm = last.right_rpm;
    fb.fault = fault;
    return fb;
  }

  DriveCall last;
  std::vector<DriveCall> calls;  // every call, oldest first (trimmed to kKeep)
  bool fault = false;
  bool measured_override = false;
  core::WheelFeedback measured;
  static constexpr std::size_t kKeep = 100000;

 private:
  void record(const DriveCall& c) {
    last = c;
    if (calls.size() == kKeep) calls.erase(calls.begin(), calls.begin() + kKeep / 2);
    calls.push_back(c);
  }
};

class FakeIntake final : public core::Intake {
 public:
  void set(bool on_) override { on = on_; }
  uint8_t rings_held() override { return rings; }
  bool on = false;
  uint8_t rings = core::kRingsUnknown;
};

/// The goal clamp: remembers what it was told; the sensor reads what the caller sets.
class FakeGoalClamp final : public core::GoalClamp {
 public:
  bool fitted() override { return actuator; }
  void set(bool closed_) override {
    if (closed_ != closed) ++changes;
    closed = closed_;
  }
  uint8_t goal_at_back() override { return sensor; }
  bool closed = false;
  uint32_t changes = 0;                  // times it was told to change state
  uint8_t sensor = core::kClampUnknown;  // 1 goal at the back, 0 none, kClampUnknown no sensor
  bool actuator = true;                  // a piston or motor is fitted
};

/// The lift: remembers what it was told.
class FakeLift final : public core::Lift {
 public:
  bool fitted() override { return actuator; }
  void set(bool up_) override {
    if (up_ != up) ++changes;
    up = up_;
  }
  bool up = false;
  uint32_t changes = 0;
  bool actuator = true;
};

class FakeCompetition final : public core::Competition {
 public:
  core::CompetitionStatus read() override { return status; }
  void set_phase(msg::MatchPhase phase) {
    status.enabled = phase != msg::MatchPhase::disabled;
    status.autonomous = phase == msg::MatchPhase::autonomous;
  }
  core::CompetitionStatus status;
};

class FakeDriverInput final : public core::DriverInput {
 public:
  core::DriverSticks read() override { return sticks; }
  core::DriverSticks sticks;
};

/// The V5 screen's alliance pick: what the caller sets (none by default).
class FakeScreen final : public core::AllianceInput {
 public:
  msg::Alliance read() override { return pick; }
  msg::Alliance pick = msg::Alliance::unknown;
};

/// One end of a VEXlink in memory: what the core writes goes to `sent`; the test (or brain_host's
/// side channel) puts the partner's bytes in `rx`. `room` is the transmit queue's free bytes.
class FakeRadio final : public core::Radio {
 public:
  bool fitted() override { return is_fitted; }
  bool connected() override { return is_fitted && linked; }
  bool write(const uint8_t* data, std::size_t n) override {
    if (!connected() || n > room) return false;
    sent.insert(sent.end(), data, data + n);
    return true;
  }
  std::size_t read(uint8_t* buf, std::size_t cap) override {
    std::size_t k = 0;
    while (k < cap && !rx.empty()) {
      buf[k++] = rx.front();
      rx.pop_front();
    }
    return k;
  }

  bool is_fitted = false;
  bool linked = false;
  std::size_t room = 512;
  std::deque<uint8_t> rx;
  std::vector<uint8_t> sent;
};

/// PROS's serial stream framing of one write(): COBS(stream id || payload) || 0x00.
std::vector<uint8_t> pros_frame(const char (&stream)[5], const uint8_t* data, std::size_t n);

/// The serial link in memory: downlink bytes the test pushes in, and the uplink as PROS would put
/// it on the wire (each packet one `pete` frame, each text write one `sout` frame).
class MemorySerial final : public core::SerialLink {
 public:
  std::size_t read(uint8_t* buf, std::size_t cap) override;
  bool write_packet(const uint8_t* data, std::size_t n) override;
  void write_text(const char* text, std::size_t n) override;

  void push_rx(const std::string& bytes) { rx.insert(rx.end(), bytes.begin(), bytes.end()); }
  void push_rx(const uint8_t* data, std::size_t n) { rx.insert(rx.end(), data, data + n); }
  /// Decode every packet written since the last call (the uplink packets, not the wire bytes).
  std::vector<msg::AnyMessage> take_messages();

  std::deque<uint8_t> rx;
  std::vector<uint8_t> wire;                  // every uplink byte, PROS-framed
  std::vector<std::vector<uint8_t>> packets;  // packets not yet taken
  std::string text;                           // everything written to stdout
  bool refuse_writes = false;
};

}  // namespace pete::host
