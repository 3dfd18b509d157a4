// The Brain core's view of the hardware: small interfaces that src/pros_adapter.cpp implements
// with PROS and brain/host/ implements with fakes. Nothing here (or anywhere in the core) includes
// a PROS header, so the whole core builds and is tested on a PC.
#pragma once

#include <cstddef>
#include <cstdint>

#include "pete/messages.hpp"

namespace pete::core {

// Interfaces are only ever used through references to objects owned elsewhere, so a protected
// non-virtual destructor is enough and keeps the classes free of deleting destructors.

/// Time since power-up: pros::millis() / pros::micros() on the Brain.
class Clock {
 public:
  virtual uint32_t now_ms() const = 0;
  virtual uint64_t now_us() const = 0;

 protected:
  ~Clock() = default;
};

/// One reading of the VEX GPS in its own frame: origin at the field centre, metres, heading in
/// degrees [0, 360) clockwise. `status` says whether the numbers mean anything.
struct GpsReading {
  msg::GpsStatus status = msg::GpsStatus::absent;
  double x_m = 0.0;
  double y_m = 0.0;
  double heading_deg = 0.0;
  double error_m = 0.0;  // the sensor's own RMS error estimate
};

class PoseSource {
 public:
  virtual GpsReading read() = 0;

 protected:
  ~PoseSource() = default;
};

/// The V5 inertial sensor: its cumulative clockwise rotation in degrees (pros::Imu::get_rotation),
/// valid only when `ok` (false while it calibrates, when it is unplugged or none is fitted).
struct ImuReading {
  bool ok = false;
  double rotation_deg = 0.0;
};

class Imu {
 public:
  virtual ImuReading read() = 0;

 protected:
  ~Imu() = default;
};

/// What the drive motors report back.
struct WheelFeedback {
  float left_rpm = 0.0f;   // motor output shaft, averaged over the side's motors
  float right_rpm = 0.0f;
  bool fault = false;      // a motor unplugged, over temperature, over current or in driver fault
};

/// The two sides of a differential drive.
class Drivetrain {
 public:
  /// Motor output-shaft speeds in rpm (what pros::MotorGroup::move_velocity takes); positive
  /// drives the robot forward. The core has already limited them to the cartridge's range.
  virtual void drive_rpm(float left_rpm, float right_rpm) = 0;
  /// Stop now, holding as the configured brake mode says.
  virtual void stop() = 0;
  virtual WheelFeedback feedback() = 0;

 protected:
  ~Drivetrain() = default;
};

/// What Intake::rings_held() says when no ring counter is fitted (the State carries it as is).
inline constexpr uint8_t kRingsUnknown = 255;

class Intake {
 public:
  virtual void set(bool on) = 0;
  /// Rings in the intake as a sensor counts them, or kRingsUnknown. The core never guesses.
  virtual uint8_t rings_held() = 0;

 protected:
  ~Intake() = default;
};

/// What GoalClamp::goal_at_back() says when no goal sensor is fitted (the State carries it as is).
inline constexpr uint8_t kClampUnknown = 255;

/// The mobile-goal clamp on the robot's back: an actuator (a pneumatic piston or a motor) and a
/// sensor (a limit switch or bumper) that a goal presses when it sits in the clamp's mouth.
class GoalClamp {
 public:
  /// Whether an actuator is fitted (false: the State says clamp absent).
  virtual bool fitted() = 0;
  /// Close (true) or open (false) the clamp. Called every loop step with the wanted state.
  virtual void set(bool closed) = 0;
  /// 1 while a goal is at the back, 0 while none is, or kClampUnknown when no sensor is fitted.
  /// The core never guesses: without a sensor it never closes the clamp by itself.
  virtual uint8_t goal_at_back() = 0;

 protected:
  ~GoalClamp() = default;
};

/// The lift that puts rings on a goal's high branch: a piston or a motor, up or down.
class Lift {
 public:
  /// Whether one is fitted (false: the State says lift absent).
  virtual bool fitted() = 0;
  /// Raise (true) or lower (false) it. Called every loop step with the wanted state.
  virtual void set(bool up) = 0;

 protected:
  ~Lift() = default;
};

/// The USB serial link to the Jetson. On the Brain, reads come from stdin (filled by a reader task,
/// so they never block the control loop) and each packet is one write() to the `pete` stream,
/// which PROS frames as COBS(stream id || packet) || 0x00.
class SerialLink {
 public:
  /// Copy downlink bytes that have already arrived into `buf`, without blocking. Returns the count.
  virtual std::size_t read(uint8_t* buf, std::size_t cap) = 0;
  /// One whole packet in one write() to the pete stream. False if it was dropped.
  virtual bool write_packet(const uint8_t* data, std::size_t n) = 0;
  /// Human-readable text on stdout (PROS's `sout` stream), for someone watching `pros terminal`.
  virtual void write_text(const char* text, std::size_t n) = 0;

 protected:
  ~SerialLink() = default;
};

/// The V5 radio's VEXlink to the alliance partner's Brain (pros::Link's raw calls; the core frames
/// its own packets). Reads and writes never block.
class Radio {
 public:
  /// Whether a radio is configured for the partner link (false: the link is absent).
  virtual bool fitted() = 0;
  /// Whether the partner's radio is linked to ours (link_connected).
  virtual bool connected() = 0;
  /// Queue `n` bytes for the partner, all or none: false when the transmit queue lacks room.
  virtual bool write(const uint8_t* data, std::size_t n) = 0;
  /// Copy bytes that have already arrived into `buf`. Returns the count.
  virtual std::size_t read(uint8_t* buf, std::size_t cap) = 0;

 protected:
  ~Radio() = default;
};

/// pros::competition's view of the field: PROS has no match clock, only these bits.
struct CompetitionStatus {
  bool enabled = false;
  bool autonomous = false;
  bool connected = false;  // to a competition switch or field controller
};

class Competition {
 public:
  virtual CompetitionStatus read() = 0;

 protected:
  ~Competition() = default;
};

/// The V5 controller, as opcontrol() samples it. Axes in [-1, 1]; `present` is false when no one
/// is holding a connected controller in driver control (so the core ignores it).
struct DriverSticks {
  bool present = false;
  float forward = 0.0f;  // left stick, up = forward
  float turn = 0.0f;     // right stick, right = clockwise
  bool intake = false;   // R1 held
  bool clamp = false;    // L1 held: each press toggles the goal clamp
  bool lift = false;     // R2 held: each press toggles the lift
};

class DriverInput {
 public:
  virtual DriverSticks read() = 0;

 protected:
  ~DriverInput() = default;
};

/// The alliance the driver picked on the V5 screen before the match (the PROS adapter's LLEMU
/// buttons): red, blue, or unknown for no pick (then the Brain finds it: alliance.hpp).
class AllianceInput {
 public:
  virtual msg::Alliance read() = 0;

 protected:
  ~AllianceInput() = default;
};

/// Everything the core drives or reads, bundled so Robot takes one argument.
struct Hardware {
  Clock& clock;
  PoseSource& gps;
  Imu& imu;
  Drivetrain& drive;
  Intake& intake;
  GoalClamp& clamp;
  Lift& lift;
  SerialLink& serial;
  Competition& competition;
  DriverInput& driver;
  AllianceInput& screen;
  Radio& radio;
};

}  // namespace pete::core
