// The ONE file of the Brain firmware that includes PROS headers: it implements the core's hardware
// interfaces (pete/core/hal.hpp) with PROS 4 devices and holds the PROS entry points.
//
// Tasks:
//   pete loop  created in initialize(), priority default+1: Robot::step() every loop_period_ms on
//              Task::delay_until, for the whole power-up. PROS deletes and re-creates the
//              competition task (autonomous/opcontrol/disabled) on every status change, so nothing
//              that must keep running lives there.
//   pete rx    created in initialize(): blocks in read() on stdin and moves the bytes into a
//              lock-free ring the loop drains, so the loop never blocks on the serial port.
//   opcontrol  PROS's competition task in driver control: samples the V5 controller every 10 ms
//              into a mailbox the loop reads. When PROS ends opcontrol (any status change), the
//              samples go stale within 100 ms and the core ignores the controller.
//
// PROS 3.8 differences (brain/README.md, "PROS 3"): pros::MotorGroup is pros::Motor_Group, with
// non-const methods, set_brake_modes and vector-returning per-motor getters; the gear and brake
// enums are the C E_MOTOR_GEARSET_* / E_MOTOR_BRAKE_*; pros::Gps::get_status() replaces
// get_position_and_orientation(); pros::adi::DigitalOut / DigitalIn are pros::ADIDigitalOut /
// ADIDigitalIn. Tasks, millis, stdin, /ser/ streams, serctl, pros::competition and the controller
// are the same.
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <vector>

#include "api.h"
#include "pete/core/byte_ring.hpp"
#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/core/robot.hpp"
#include "pete/messages.hpp"
#include "pros/apix.h"

// LLEMU (the V5 screen's three buttons, for the alliance pick) is PROS 4's liblvgl template;
// PROS's common.mk defines _PROS_INCLUDE_LIBLVGL_LLEMU_HPP when the template is applied.
#if defined(_PROS_INCLUDE_LIBLVGL_LLEMU_HPP)
#include "liblvgl/llemu.hpp"
#define PETE_HAS_LLEMU 1
#else
#define PETE_HAS_LLEMU 0
#endif

namespace {

using namespace pete;

constexpr core::Config kConfig = core::kRobotConfig;
constexpr core::Ports kPorts = core::kRobotPorts;

// --- clock, competition --------------------------------------------------------------------------

class ProsClock final : public core::Clock {
 public:
  uint32_t now_ms() const override { return pros::millis(); }
  uint64_t now_us() const override { return pros::micros(); }
};

class ProsCompetition final : public core::Competition {
 public:
  core::CompetitionStatus read() override {
    core::CompetitionStatus s;
    s.enabled = pros::competition::is_disabled() == 0;
    s.autonomous = pros::competition::is_autonomous() != 0;
    s.connected = pros::competition::is_connected() != 0;
    return s;
  }
};

// --- GPS -----------------------------------------------------------------------------------------

class ProsGps final : public core::PoseSource {
 public:
  ProsGps() {
    if (kPorts.gps != 0) gps_.emplace(kPorts.gps, kPorts.gps_offset_x_m, kPorts.gps_offset_y_m);
  }

  core::GpsReading read() override {
    core::GpsReading r;
    if (!gps_) return r;  // absent: no GPS configured
    errno = 0;
    const pros::gps_status_s_t s = gps_->get_position_and_orientation();
    const double x = s.x;  // the struct is packed: copy out before use
    const double y = s.y;
    if (x == PROS_ERR_F || y == PROS_ERR_F) return failed(errno);
    errno = 0;
    const double heading = gps_->get_heading();
    if (heading == PROS_ERR_F) return failed(errno);
    const double error = gps_->get_error();
    if (error == PROS_ERR_F) return failed(errno);
    r.status = msg::GpsStatus::ok;
    r.x_m = x;
    r.y_m = y;
    r.heading_deg = heading;  // [0, 360) clockwise, the protocol's convention
    r.error_m = error;
    return r;  // the core checks the numbers themselves (finite, on the field)
  }

 private:
  static core::GpsReading failed(int err) {
    core::GpsReading r;
    // PROS: ENODEV = no GPS on that port, EAGAIN = still calibrating, ENXIO = bad port number.
    r.status = err == ENODEV    ? msg::GpsStatus::absent
               : err == EAGAIN ? msg::GpsStatus::calibrating
                               : msg::GpsStatus::error;
    return r;
  }

  std::optional<pros::Gps> gps_;
};

// --- inertial sensor -----------------------------------------------------------------------------

/// The V5 inertial sensor (Ports::imu): its cumulative rotation about the vertical axis, degrees
/// clockwise (pros::Imu::get_rotation). Calibration starts at power-up (reset(), not blocking,
/// about 2 s); until it ends, and whenever the sensor fails, the reading is not ok and the pose
/// filter turns with the wheels alone.
class ProsImu final : public core::Imu {
 public:
  ProsImu() {
    if (kPorts.imu != 0) {
      imu_.emplace(kPorts.imu);
      imu_->reset(false);
    }
  }

  core::ImuReading read() override {
    core::ImuReading r;
    if (!imu_) return r;
    const double rotation = imu_->get_rotation();  // PROS_ERR_F (EAGAIN) while calibrating
    if (rotation == PROS_ERR_F) return r;
    r.ok = true;
    r.rotation_deg = rotation;
    return r;
  }

 private:
  std::optional<pros::Imu> imu_;
};

// --- motors --------------------------------------------------------------------------------------

pros::MotorGears gears(float cartridge_rpm) {
  if (cartridge_rpm == 100.0f) return pros::MotorGears::red;
  if (cartridge_rpm == 200.0f) return pros::MotorGears::green;
  return pros::MotorGears::blue;  // config_error() allows only 100, 200 and 600
}

pros::MotorBrake brake_mode(core::BrakeMode m) {
  switch (m) {
    case core::BrakeMode::coast:
      return pros::MotorBrake::coast;
    case core::BrakeMode::hold:
      return pros::MotorBrake::hold;
    case core::BrakeMode::brake:
      break;
  }
  return pros::MotorBrake::brake;
}

// Start-up only (MotorGroup takes a vector): the one place the firmware allocates.
std::vector<std::int8_t> port_list(const int8_t (&ports)[core::kMaxMotorsPerSide]) {
  std::vector<std::int8_t> out;
  for (int8_t p : ports) {
    if (p != 0) out.push_back(p);
  }
  return out;
}

struct SideReading {
  float rpm = 0.0f;
  bool fault = false;
};

SideReading read_side(const pros::MotorGroup& group) {
  SideReading r;
  const std::int8_t n = group.size();
  if (n <= 0) {
    r.fault = true;
    return r;
  }
  double sum = 0.0;
  for (std::int8_t i = 0; i < n; ++i) {
    const auto index = static_cast<std::uint8_t>(i);
    const double v = group.get_actual_velocity(index);
    const std::uint32_t faults = group.get_faults(index);
    // PROS_ERR / PROS_ERR_F: the motor is unplugged or the port holds something else.
    if (v == PROS_ERR_F || faults == static_cast<std::uint32_t>(PROS_ERR) || faults != 0) {
      r.fault = true;
    }
    if (v != PROS_ERR_F) sum += v;
  }
  r.rpm = static_cast<float>(sum / n);
  return r;
}

class ProsDrivetrain final : public core::Drivetrain {
 public:
  ProsDrivetrain()
      : left_(port_list(kPorts.left), gears(kConfig.drive.cartridge_rpm)),
        right_(port_list(kPorts.right), gears(kConfig.drive.cartridge_rpm)) {
    left_.set_brake_mode_all(brake_mode(kConfig.drive.brake_mode));
    right_.set_brake_mode_all(brake_mode(kConfig.drive.brake_mode));
  }

  void drive_rpm(float left_rpm, float right_rpm) override {
    left_.move_velocity(round_rpm(left_rpm));
    right_.move_velocity(round_rpm(right_rpm));
  }
  void stop() override {
    left_.brake();
    right_.brake();
  }
  core::WheelFeedback feedback() override {
    const SideReading l = read_side(left_);
    const SideReading r = read_side(right_);
    core::WheelFeedback fb;
    fb.left_rpm = l.rpm;
    fb.right_rpm = r.rpm;
    fb.fault = l.fault || r.fault;
    return fb;
  }

 private:
  static std::int32_t round_rpm(float rpm) {
    return static_cast<std::int32_t>(rpm < 0.0f ? rpm - 0.5f : rpm + 0.5f);
  }

  pros::MotorGroup left_;
  pros::MotorGroup right_;
};

class ProsIntake final : public core::Intake {
 public:
  ProsIntake() {
    if (kPorts.intake[0] != 0) {
      group_.emplace(port_list(kPorts.intake), pros::MotorGears::blue);
      group_->set_brake_mode_all(pros::MotorBrake::coast);
    }
  }
  // No ring counter is wired by default. A team that fits one (an optical sensor at the intake's
  // exit, say) counts its rising edges here; the Jetson then sees real counts in the State.
  uint8_t rings_held() override { return core::kRingsUnknown; }
  void set(bool on) override {
    if (!group_ || on == on_) return;
    on_ = on;
    if (on) {
      group_->move_velocity(static_cast<std::int32_t>(kPorts.intake_rpm));
    } else {
      group_->brake();
    }
  }

 private:
  std::optional<pros::MotorGroup> group_;
  bool on_ = true;  // so the first set(false) really stops it
};

// --- goal clamp and lift ------------------------------------------------------------------------

/// A two-position actuator: a pneumatic solenoid on an ADI port, or a smart motor that moves
/// between 0 (its position at power-up) and `on_deg` and holds there. Which one (or none) is
/// chosen in kRobotPorts; config.hpp's ports_error() refuses both at once.
class TwoPosition {
 public:
  TwoPosition(uint8_t adi_port, bool on_high, std::int8_t motor_port, float on_deg)
      : on_high_(on_high), on_deg_(on_deg) {
    // Both start in the "off" position (open clamp, lowered lift), so power-up moves nothing.
    if (adi_port != 0) {
      piston_.emplace(adi_port, level(false));
    } else if (motor_port != 0) {
      motor_.emplace(motor_port, pros::MotorGears::green);
      motor_->set_brake_mode(pros::MotorBrake::hold);
      motor_->tare_position();
    }
  }

  bool fitted() const { return piston_.has_value() || motor_.has_value(); }

  void set(bool on) {
    if (!fitted() || (known_ && on == on_)) return;
    known_ = true;
    on_ = on;
    if (piston_) {
      piston_->set_value(level(on) ? 1 : 0);
    } else {
      motor_->move_absolute(on ? on_deg_ : 0.0,
                            static_cast<std::int32_t>(kPorts.actuator_motor_rpm));
    }
  }

 private:
  bool level(bool on) const { return on == on_high_; }

  bool on_high_;
  double on_deg_;
  std::optional<pros::adi::DigitalOut> piston_;
  std::optional<pros::Motor> motor_;
  bool known_ = false;
  bool on_ = false;
};

/// The mobile-goal clamp: a piston (Ports::clamp_piston) or a motor (Ports::clamp_motor), and a
/// limit switch or bumper at the clamp's mouth (Ports::clamp_sensor), pressed while a goal sits at
/// the back. None is fitted as shipped: the State then says clamp absent and goal_clamped 255.
class ProsGoalClamp final : public core::GoalClamp {
 public:
  ProsGoalClamp()
      : actuator_(kPorts.clamp_piston, kPorts.clamp_closes_high, kPorts.clamp_motor,
                  kPorts.clamp_motor_closed_deg) {
    if (kPorts.clamp_sensor != 0) sensor_.emplace(kPorts.clamp_sensor);
  }

  bool fitted() override { return actuator_.fitted(); }
  void set(bool closed) override { actuator_.set(closed); }

  uint8_t goal_at_back() override {
    if (!sensor_) return core::kClampUnknown;
    // 1 while the switch is pressed, 0 while released; PROS_ERR (errno set) when the port fails.
    const std::int32_t v = sensor_->get_value();
    if (v == PROS_ERR) return core::kClampUnknown;
    return v != 0 ? 1 : 0;
  }

 private:
  TwoPosition actuator_;
  std::optional<pros::adi::DigitalIn> sensor_;
};

/// The lift that reaches the high branch: a piston (Ports::lift_piston) or a motor
/// (Ports::lift_motor); none as shipped (the State says lift absent).
class ProsLift final : public core::Lift {
 public:
  ProsLift()
      : actuator_(kPorts.lift_piston, kPorts.lift_up_high, kPorts.lift_motor,
                  kPorts.lift_motor_up_deg) {}
  bool fitted() override { return actuator_.fitted(); }
  void set(bool up) override { actuator_.set(up); }

 private:
  TwoPosition actuator_;
};

// --- serial --------------------------------------------------------------------------------------

/// "pete" as serctl wants a stream id: the four ASCII bytes read as a little-endian u32.
constexpr std::uint32_t stream_id_le(const char (&id)[wire::kStreamIdSize + 1]) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(id[0])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(id[1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(id[2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(id[3])) << 24;
}

class ProsSerial final : public core::SerialLink {
 public:
  /// Open our own stream, /ser/pete, and switch it on (PROS silently drops writes to a stream
  /// that was never activated). Unbuffered, so each packet is exactly one write() and so one
  /// PROS frame: COBS("pete" || packet) || 0x00.
  bool open() {
    static constexpr char kPath[] = {'/', 's', 'e', 'r', '/', msg::kStream[0], msg::kStream[1],
                                     msg::kStream[2], msg::kStream[3], '\0'};
    FILE* f = std::fopen(kPath, "w");
    if (f == nullptr) return false;
    std::setvbuf(f, nullptr, _IONBF, 0);
    fd_ = fileno(f);
    pros::c::serctl(SERCTL_ACTIVATE, reinterpret_cast<void*>(stream_id_le(msg::kStream)));
    return true;
  }

  std::size_t read(uint8_t* buf, std::size_t cap) override { return rx_.pop(buf, cap); }

  bool write_packet(const uint8_t* data, std::size_t n) override {
    if (fd_ < 0) return false;
    return ::write(fd_, data, n) == static_cast<ssize_t>(n);
  }

  void write_text(const char* text, std::size_t n) override { ::write(STDOUT_FILENO, text, n); }

  /// The rx task's body: never returns.
  [[noreturn]] void pump_stdin() {
    // PROS's read() stores a NUL after the bytes it returns: leave room for it.
    uint8_t buf[129];
    for (;;) {
      const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf - 1);
      if (n > 0) {
        rx_.push(buf, static_cast<std::size_t>(n));
      } else {
        pros::delay(2);
      }
    }
  }

 private:
  core::ByteRing<4096> rx_;
  int fd_ = -1;
};

// --- VEXlink ----------------------------------------------------------------------------------

/// The partner link's radio through PROS's raw VEXlink calls (the core frames its own packets).
/// link_init fails (and the link is absent) when no radio is configured or plugged in; VEXlink
/// then takes 1-2 s to find the partner, which connected() reports.
class ProsRadio final : public core::Radio {
 public:
  void start() {
    if (kPorts.radio == 0) return;
    // PROS's header spells the receiver E_LINK_RECIEVER (every version; E_LINK_RX only in some).
    const pros::link_type_e_t type =
        kPorts.radio_transmitter ? pros::E_LINK_TRANSMITTER : pros::E_LINK_RECIEVER;
    fitted_ = pros::c::link_init(kPorts.radio, kPorts.link_id, type) != PROS_ERR;
  }
  bool fitted() override { return fitted_; }
  bool connected() override { return fitted_ && pros::c::link_connected(kPorts.radio); }
  bool write(const uint8_t* data, std::size_t n) override {
    if (!connected() || n > 0xFFFF) return false;
    const std::uint32_t room = pros::c::link_raw_transmittable_size(kPorts.radio);
    if (room == PROS_ERR || room < n) return false;  // all or none: EBUSY otherwise
    const std::uint32_t sent = pros::c::link_transmit_raw(
        kPorts.radio, const_cast<uint8_t*>(data), static_cast<std::uint16_t>(n));
    return sent == n;
  }
  std::size_t read(uint8_t* buf, std::size_t cap) override {
    if (!connected()) return 0;
    const std::uint32_t ready = pros::c::link_raw_receivable_size(kPorts.radio);
    if (ready == PROS_ERR || ready == 0) return 0;
    const std::size_t want = ready < cap ? ready : cap;
    const std::uint32_t got =
        pros::c::link_receive_raw(kPorts.radio, buf, static_cast<std::uint16_t>(want));
    return got == PROS_ERR ? 0 : got;
  }

 private:
  bool fitted_ = false;
};

// --- controller ----------------------------------------------------------------------------------

/// opcontrol() publishes controller samples here; the loop reads the newest if it is fresh.
class ProsDriverInput final : public core::DriverInput {
 public:
  static constexpr std::uint32_t kFreshMs = 100;

  void publish(std::int32_t forward, std::int32_t turn, bool intake, bool clamp, bool lift) {
    const std::uint32_t packed = static_cast<std::uint8_t>(static_cast<std::int8_t>(forward)) |
                                 static_cast<std::uint32_t>(static_cast<std::uint8_t>(
                                     static_cast<std::int8_t>(turn)))
                                     << 8 |
                                 (intake ? 1u << 16 : 0u) | (clamp ? 1u << 17 : 0u) |
                                 (lift ? 1u << 18 : 0u);
    sample_.store(packed, std::memory_order_relaxed);
    stamp_ms_.store(pros::millis(), std::memory_order_release);
  }

  core::DriverSticks read() override {
    core::DriverSticks s;
    const std::uint32_t stamp = stamp_ms_.load(std::memory_order_acquire);
    if (stamp == 0 || pros::millis() - stamp > kFreshMs) return s;  // opcontrol is not running
    const std::uint32_t packed = sample_.load(std::memory_order_relaxed);
    s.present = true;
    s.forward = static_cast<float>(static_cast<std::int8_t>(packed & 0xFF)) / 127.0f;
    s.turn = static_cast<float>(static_cast<std::int8_t>((packed >> 8) & 0xFF)) / 127.0f;
    s.intake = (packed >> 16) & 1u;
    s.clamp = (packed >> 17) & 1u;
    s.lift = (packed >> 18) & 1u;
    return s;
  }

 private:
  std::atomic<std::uint32_t> sample_{0};
  std::atomic<std::uint32_t> stamp_ms_{0};
};

// --- the V5 screen: the alliance pick ------------------------------------------------------------

/// Before the match the driver picks the alliance on the Brain's screen with LLEMU's three buttons:
/// left = red, right = blue, centre = no pick (the Brain finds it from the GPS start pose). The
/// screen shows the pick. LLEMU lives in PROS 4's liblvgl template (`pros conduct apply liblvgl`);
/// without it (PETE_HAS_LLEMU 0, above) this reads "no pick" and the GPS decides.

std::atomic<std::uint8_t> g_screen_pick{static_cast<std::uint8_t>(msg::Alliance::unknown)};

class ProsScreen final : public core::AllianceInput {
 public:
  void start() {
#if PETE_HAS_LLEMU
    pros::lcd::initialize();
    pros::lcd::register_btn0_cb(&ProsScreen::pick_red);
    pros::lcd::register_btn1_cb(&ProsScreen::pick_none);
    pros::lcd::register_btn2_cb(&ProsScreen::pick_blue);
    show(msg::Alliance::unknown);
#endif
  }
  msg::Alliance read() override {
    const auto v = static_cast<msg::Alliance>(g_screen_pick.load(std::memory_order_relaxed));
    return msg::is_valid(v) ? v : msg::Alliance::unknown;
  }

 private:
  static void set(msg::Alliance a) {
    g_screen_pick.store(static_cast<std::uint8_t>(a), std::memory_order_relaxed);
    show(a);
  }
  static void pick_red() { set(msg::Alliance::red); }
  static void pick_blue() { set(msg::Alliance::blue); }
  static void pick_none() { set(msg::Alliance::unknown); }
  static void show(msg::Alliance a) {
#if PETE_HAS_LLEMU
    pros::lcd::set_text(0, "pete: alliance (left red, right blue, centre GPS)");
    pros::lcd::set_text(1, a == msg::Alliance::red    ? "picked: RED"
                           : a == msg::Alliance::blue ? "picked: BLUE"
                                                      : "picked: none - from the GPS start pose");
#else
    (void)a;
#endif
  }
};

// --- the robot -----------------------------------------------------------------------------------

struct ProsHardware {
  ProsClock clock;
  ProsGps gps;
  ProsImu imu;
  ProsDrivetrain drive;
  ProsIntake intake;
  ProsGoalClamp clamp;
  ProsLift lift;
  ProsSerial serial;
  ProsCompetition competition;
  ProsDriverInput driver;
  ProsScreen screen;
  ProsRadio radio;

  core::Hardware hal() {
    return {clock, gps, imu, drive, intake, clamp, lift, serial, competition, driver, screen, radio};
  }
};

ProsHardware* g_hardware = nullptr;

/// Random enough per power-up that the Jetson notices a restart: the microsecond timer after the
/// devices came up, mixed with the battery's analogue readings (FNV-1a).
std::uint32_t make_boot_id() {
  std::uint32_t h = 2166136261u;
  auto mix = [&h](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) {
      h = (h ^ ((v >> (8 * i)) & 0xFFu)) * 16777619u;
    }
  };
  mix(static_cast<std::uint32_t>(pros::micros()));
  mix(static_cast<std::uint32_t>(pros::battery::get_voltage()));
  mix(static_cast<std::uint32_t>(pros::battery::get_current()));
  mix(static_cast<std::uint32_t>(pros::battery::get_temperature() * 1000.0));
  mix(static_cast<std::uint32_t>(pros::battery::get_capacity() * 1000.0));
  return h != 0 ? h : 1u;
}

void loop_task(void* arg) {
  auto* robot = static_cast<core::Robot*>(arg);
  std::uint32_t wake = pros::millis();
  for (;;) {
    robot->step();
    pros::Task::delay_until(&wake, kConfig.loop_period_ms);
  }
}

void rx_task(void* arg) { static_cast<ProsSerial*>(arg)->pump_stdin(); }

}  // namespace

// --- PROS entry points ---------------------------------------------------------------------------

extern "C" {
void initialize(void);
void disabled(void);
void competition_initialize(void);
void autonomous(void);
void opcontrol(void);
}

void initialize() {
  // Everything that allocates happens here, once: device objects, the robot, the two tasks.
  static ProsHardware hardware;
  g_hardware = &hardware;
  hardware.screen.start();
  hardware.radio.start();
  if (!hardware.serial.open()) {
    std::fputs("pete: cannot open /ser/pete; the Jetson link is down\n", stderr);
  }
  static core::Robot robot(kConfig, hardware.hal(), make_boot_id());
  pros::Task rx(rx_task, &hardware.serial, TASK_PRIORITY_DEFAULT, TASK_STACK_DEPTH_DEFAULT,
                "pete rx");
  pros::Task loop(loop_task, &robot, TASK_PRIORITY_DEFAULT + 1, TASK_STACK_DEPTH_DEFAULT,
                  "pete loop");
}

// The loop task watches pros::competition itself, so these have nothing to do.
void disabled() {}
void competition_initialize() {}
void autonomous() {}

void opcontrol() {
  pros::Controller master(pros::E_CONTROLLER_MASTER);
  std::uint32_t wake = pros::millis();
  for (;;) {
    if (g_hardware != nullptr && master.is_connected() == 1) {
      g_hardware->driver.publish(master.get_analog(pros::E_CONTROLLER_ANALOG_LEFT_Y),
                                 master.get_analog(pros::E_CONTROLLER_ANALOG_RIGHT_X),
                                 master.get_digital(pros::E_CONTROLLER_DIGITAL_R1) == 1,
                                 master.get_digital(pros::E_CONTROLLER_DIGITAL_L1) == 1,
                                 master.get_digital(pros::E_CONTROLLER_DIGITAL_R2) == 1);
    }
    pros::Task::delay_until(&wake, 10);
  }
}
