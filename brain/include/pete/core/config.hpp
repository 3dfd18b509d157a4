// The robot's configuration: the ONE file a team edits for its robot (ports, geometry, link timing,
// who may drive when). brain/README.md walks through every value.
//
// Everything is constexpr and checked at compile time (config_error), so a robot with an impossible
// configuration does not build, rather than driving wrongly.
#pragma once

#include <cstddef>
#include <cstdint>

#include "pete/core/alliance.hpp"
#include "pete/core/match_clock.hpp"
#include "pete/core/pose_filter.hpp"
#include "pete/messages.hpp"

namespace pete::core {

enum class BrakeMode : uint8_t { coast, brake, hold };

/// Geometry and limits of the differential drive.
struct DriveConfig {
  float track_width_m;      // between the left and right wheels' contact lines
  float wheel_diameter_m;   // of the driven wheels (VEX "4 in" omni wheels are about 0.1048 m)
  float gear_ratio;         // wheel turns per motor-shaft turn: 36T on the motor driving 48T = 0.75
  float cartridge_rpm;      // motor cartridge free speed: 100 (red), 200 (green) or 600 (blue)
  float max_speed_fraction; // of the free speed the core may command; the rest is PID headroom
  float max_linear_accel;   // m/s^2, slew limit on the commanded forward speed
  float max_angular_accel;  // rad/s^2, slew limit on the commanded turn rate
  BrakeMode brake_mode;     // how the motors hold when the core stops them
};

/// Timing of the Brain <-> Jetson link.
struct LinkConfig {
  uint32_t hello_period_ms;           // Hello cadence until the Jetson answers
  uint32_t state_period_ms;           // State cadence after the handshake (20 ms = 50 Hz)
  uint32_t default_command_valid_ms;  // used when a Command says valid_ms = 0
  uint32_t max_command_valid_ms;      // longer windows are cut to this
};

/// Arcade drive from the V5 controller in driver control.
struct DriverConfig {
  float max_linear_mps;      // full stick forward
  float max_angular_rps;     // full stick sideways, rad/s
  float deadband;            // stick travel (0..1) treated as centred
  uint32_t override_hold_ms; // a stick move takes over from the Jetson for this long after release
};

/// The mobile-goal clamp on the robot's back. The Jetson holds or releases it (Command.clamp); left
/// to itself, the Brain closes it when its sensor says a goal is at the back, as the simulator's
/// auto clamp does, and keeps it closed.
struct ClampConfig {
  bool auto_close;      // close the clamp by itself (autonomous and driver control, never disabled)
  uint32_t confirm_ms;  // ...once the sensor has said "goal" this long without a break (0: at once)
};

/// The partner link over VEXlink (partner.hpp).
struct PartnerConfig {
  uint32_t period_ms;         // our newest report goes over the radio at most this often
  uint32_t report_max_age_ms; // a report of ours older than this is not sent (the Jetson went quiet)
  uint32_t timeout_ms;        // no partner report for this long: the link is lost
  uint32_t status_period_ms;  // PartnerStatus to the Jetson this often (and on every change)
};

struct Config {
  DriveConfig drive;
  LinkConfig link;
  DriverConfig driver;
  ClampConfig clamp;
  uint32_t loop_period_ms;           // control loop period; the loop never runs faster or slower
  msg::Alliance alliance;            // unknown: found at run time (alliance.hpp); red/blue: fixed
  bool jetson_drives_in_autonomous;  // VEX AI: both periods are autonomous, so both default to true
  bool jetson_drives_in_driver;
  MatchTiming match;                 // VEX AI: isolation 15 s, interaction 105 s
  PoseFilterConfig pose;             // the GPS + odometry + IMU filter (pose_filter.hpp)
  AllianceConfig find_alliance;      // how the alliance is found at run time
  PartnerConfig partner;             // the partner link over VEXlink
};

/// Motor and sensor ports: used only by src/pros_adapter.cpp. 0 = unused slot; a negative port
/// reverses that motor (PROS convention), so both sides can be written "forward = positive".
inline constexpr std::size_t kMaxMotorsPerSide = 4;
struct Ports {
  int8_t left[kMaxMotorsPerSide];
  int8_t right[kMaxMotorsPerSide];
  int8_t intake[kMaxMotorsPerSide];
  uint8_t gps;               // 0 = no GPS fitted (State always says absent)
  double gps_offset_x_m;     // GPS sensor position relative to the robot's turning centre,
  double gps_offset_y_m;     //   as pros::Gps(port, xOffset, yOffset) takes it
  float intake_rpm;          // intake motor speed when running
  // The goal clamp's actuator: a pneumatic piston on an ADI port OR a motor (not both; neither =
  // no clamp, and the State says clamp absent).
  uint8_t clamp_piston;      // ADI port (1..8 or 'A'..'H') of the clamp's solenoid; 0 = none
  uint8_t clamp_sensor;      // ADI port of the switch a goal at the back presses; 0 = none fitted
  bool clamp_closes_high;    // the solenoid level that closes the clamp (false: LOW closes it)
  int8_t clamp_motor;        // smart port of a clamp motor (negative reverses it); 0 = none
  float clamp_motor_closed_deg;  // motor-shaft angle that closes the clamp, from the open one at
                                 //   power-up (the motor holds it there)
  // The lift that reaches the high branch: a piston OR a motor, as the clamp (neither = none).
  uint8_t lift_piston;       // ADI port of the lift's solenoid; 0 = none
  bool lift_up_high;         // the solenoid level that raises the lift
  int8_t lift_motor;         // smart port of a lift motor; 0 = none
  float lift_motor_up_deg;   // motor-shaft angle of the raised lift, from the lowered one at power-up
  float actuator_motor_rpm;  // speed of a clamp or lift motor while it moves (green cartridge)
  uint8_t imu;               // the V5 inertial sensor's smart port; 0 = none (wheels alone turn)
  // VEXlink to the alliance partner's Brain (PROS: one link radio per Brain). The two robots of a
  // team use the same link_id; one is the transmitter end (twice the bandwidth), the other not.
  uint8_t radio;             // smart port of the link's V5 radio; 0 = none (the link is absent)
  bool radio_transmitter;    // this Brain is the link's transmitter end
  const char* link_id;       // the same text on both robots of the team
};

// --- this robot ---------------------------------------------------------------------------------

inline constexpr Config kRobotConfig{
    /*drive=*/{
        /*track_width_m=*/0.300f,
        /*wheel_diameter_m=*/0.08255f,  // 3.25 in
        /*gear_ratio=*/0.75f,           // 36:48, so a 600 rpm cartridge gives 450 rpm wheels
        /*cartridge_rpm=*/600.0f,
        /*max_speed_fraction=*/0.95f,
        /*max_linear_accel=*/3.0f,
        /*max_angular_accel=*/20.0f,
        /*brake_mode=*/BrakeMode::brake,
    },
    /*link=*/{
        /*hello_period_ms=*/200,
        /*state_period_ms=*/20,
        /*default_command_valid_ms=*/250,
        /*max_command_valid_ms=*/1000,
    },
    /*driver=*/{
        /*max_linear_mps=*/1.5f,
        /*max_angular_rps=*/6.0f,
        /*deadband=*/0.06f,
        /*override_hold_ms=*/500,
    },
    /*clamp=*/{
        /*auto_close=*/true,
        /*confirm_ms=*/0,  // the simulator's clamp closes at the first touch too
    },
    /*loop_period_ms=*/10,
    /*alliance=*/msg::Alliance::unknown,  // found at run time: the V5 screen or the GPS
    /*jetson_drives_in_autonomous=*/true,
    /*jetson_drives_in_driver=*/true,
    /*match=*/{/*isolation_ms=*/15000, /*interaction_ms=*/105000},
    /*pose=*/{
        /*gps_min_std_m=*/0.013,          // VEX quotes about +-13 mm with the strip in view
        /*gps_heading_std_deg=*/1.0,
        /*gps_max_error_m=*/0.3,          // the sensor's own RMS error above this: not used
        /*gps_latency_ms=*/30,
        /*odom_var_per_m=*/0.0025,        // 5 cm std of slip per metre driven
        /*pos_var_per_s=*/2e-5,
        /*heading_var_per_rad_imu=*/1e-4, // 1 % of the angle turned
        /*heading_var_per_s_imu=*/3e-6,   // the IMU's drift, about 0.1 deg/s^0.5
        /*heading_var_per_rad_wheels=*/0.01,
        /*heading_var_per_m_wheels=*/0.002,
        /*gate_chi2=*/16.27,              // 99.9 % of good readings pass (3 degrees of freedom)
        /*push_mps=*/0.3,                 // a pushed robot's unseen motion, while readings disagree
        /*reanchor_ms=*/1000,
        /*gps_fix_hold_ms=*/250,
        /*lost_std_m=*/1.0,
        /*slip_deadband_mps=*/0.1,        // the motors' lag behind the slew-limited command
        /*slip_var_per_m=*/0.08,          // 28 cm std per metre the wheels did not drive as told
    },
    /*find_alliance=*/{
        /*red_side_x_sign=*/-1.0f,   // red's half is x < 0 (the simulator's field file)
        /*center_margin_m=*/0.3f,
        /*lock_after_ms=*/1000,
    },
    /*partner=*/{
        /*period_ms=*/100,          // 26-byte frames: 260 bytes/s of VEXlink's slower 520
        /*report_max_age_ms=*/500,
        /*timeout_ms=*/1000,
        /*status_period_ms=*/200,
    },
};

inline constexpr Ports kRobotPorts{
    /*left=*/{-1, -2, -3, 0},
    /*right=*/{4, 5, 6, 0},
    /*intake=*/{7, 0, 0, 0},
    /*gps=*/10,
    /*gps_offset_x_m=*/0.0,
    /*gps_offset_y_m=*/-0.10,
    /*intake_rpm=*/600.0f,
    /*clamp_piston=*/0,  // none fitted: the State says goal_clamped = 255 (e.g. 'A' once wired)
    /*clamp_sensor=*/0,  //   (e.g. 'B' for a limit switch at the back)
    /*clamp_closes_high=*/true,
    /*clamp_motor=*/0,   // or a motor clamp, e.g. 8 with clamp_motor_closed_deg = 120
    /*clamp_motor_closed_deg=*/120.0f,
    /*lift_piston=*/0,   // none fitted: the State says lift absent (e.g. 'C' once wired)
    /*lift_up_high=*/true,
    /*lift_motor=*/0,    // or a motor lift, e.g. 9 with lift_motor_up_deg = 600
    /*lift_motor_up_deg=*/600.0f,
    /*actuator_motor_rpm=*/150.0f,
    /*imu=*/11,
    /*radio=*/12,
    /*radio_transmitter=*/true,  // false on the partner robot
    /*link_id=*/"pacman-pete",
};

// --- checks -------------------------------------------------------------------------------------

/// nullptr when `c` is usable, otherwise what is wrong with it.
constexpr const char* config_error(const Config& c) {
  const DriveConfig& d = c.drive;
  if (!(d.track_width_m > 0.05f && d.track_width_m < 1.0f)) return "track_width_m out of range";
  if (!(d.wheel_diameter_m > 0.01f && d.wheel_diameter_m < 0.5f)) {
    return "wheel_diameter_m out of range";
  }
  if (!(d.gear_ratio > 0.05f && d.gear_ratio < 20.0f)) return "gear_ratio out of range";
  if (d.cartridge_rpm != 100.0f && d.cartridge_rpm != 200.0f && d.cartridge_rpm != 600.0f) {
    return "cartridge_rpm must be 100, 200 or 600";
  }
  if (!(d.max_speed_fraction > 0.0f && d.max_speed_fraction <= 1.0f)) {
    return "max_speed_fraction must be in (0, 1]";
  }
  if (!(d.max_linear_accel > 0.0f) || !(d.max_angular_accel > 0.0f)) {
    return "acceleration limits must be positive";
  }
  const LinkConfig& l = c.link;
  if (l.hello_period_ms == 0 || l.state_period_ms == 0) return "link periods must be positive";
  if (l.default_command_valid_ms == 0 || l.default_command_valid_ms > l.max_command_valid_ms) {
    return "default_command_valid_ms must be in 1..max_command_valid_ms";
  }
  if (c.loop_period_ms < 2 || c.loop_period_ms > 50) return "loop_period_ms must be 2..50";
  if (l.state_period_ms % c.loop_period_ms != 0) {
    return "state_period_ms must be a multiple of loop_period_ms";
  }
  if (l.max_command_valid_ms < 2 * c.loop_period_ms) {
    return "max_command_valid_ms must cover at least two loop periods";
  }
  const DriverConfig& dr = c.driver;
  if (!(dr.max_linear_mps >= 0.0f) || !(dr.max_angular_rps >= 0.0f)) {
    return "driver speed limits must not be negative";
  }
  if (!(dr.deadband >= 0.0f && dr.deadband < 0.5f)) return "driver deadband must be in [0, 0.5)";
  if (!msg::is_valid(c.alliance)) return "alliance is not a valid Alliance";
  if (c.find_alliance.red_side_x_sign != 1.0f && c.find_alliance.red_side_x_sign != -1.0f) {
    return "find_alliance.red_side_x_sign must be 1 or -1";
  }
  if (!(c.find_alliance.center_margin_m >= 0.0f && c.find_alliance.center_margin_m < 1.5f)) {
    return "find_alliance.center_margin_m must be in [0, 1.5)";
  }
  if (c.clamp.confirm_ms > 1000) return "clamp confirm_ms must be at most 1000";
  const PoseFilterConfig& f = c.pose;
  const double pose_numbers[] = {f.gps_min_std_m, f.gps_heading_std_deg, f.gps_max_error_m,
                                 f.odom_var_per_m, f.pos_var_per_s, f.heading_var_per_rad_imu,
                                 f.heading_var_per_s_imu, f.heading_var_per_rad_wheels,
                                 f.heading_var_per_m_wheels, f.gate_chi2, f.push_mps,
                                 f.lost_std_m, f.slip_deadband_mps, f.slip_var_per_m};
  for (double v : pose_numbers) {
    if (!(v >= 0.0 && v < 1e6)) return "pose filter numbers must be finite and not negative";
  }
  if (!(f.gps_min_std_m > 0.0) || !(f.gps_heading_std_deg > 0.0) || !(f.gate_chi2 > 0.0)) {
    return "pose filter: GPS stds and the gate must be positive";
  }
  if (f.gps_latency_ms > 100) return "pose filter: gps_latency_ms must be at most 100";
  if (c.match.isolation_ms == 0 || c.match.interaction_ms <= MatchClock::kEndSlackMs ||
      c.match.isolation_ms > 600000 || c.match.interaction_ms > 600000) {
    return "match periods must be 1..600000 ms (interaction longer than 5 s)";
  }
  const PartnerConfig& pc = c.partner;
  if (pc.period_ms < 50 || pc.period_ms > 1000) return "partner period_ms must be 50..1000";
  if (pc.report_max_age_ms < pc.period_ms) return "partner report_max_age_ms must be >= period_ms";
  if (pc.timeout_ms < 2 * pc.period_ms || pc.timeout_ms > 10000) {
    return "partner timeout_ms must be 2 periods .. 10000";
  }
  if (pc.status_period_ms == 0 || pc.status_period_ms > 1000) {
    return "partner status_period_ms must be 1..1000";
  }
  return nullptr;
}

/// An ADI (three-wire) port as 1..8, from 1..8, 'A'..'H' or 'a'..'h' (what PROS takes);
/// 0 for 0 (not fitted), -1 for anything else.
constexpr int adi_port_index(uint8_t port) {
  if (port == 0) return 0;
  if (port >= 1 && port <= 8) return port;
  if (port >= 'A' && port <= 'H') return port - 'A' + 1;
  if (port >= 'a' && port <= 'h') return port - 'a' + 1;
  return -1;
}

constexpr const char* ports_error(const Ports& p) {
  bool used[22] = {};
  const int8_t actuators[kMaxMotorsPerSide] = {p.clamp_motor, p.lift_motor, 0, 0};
  const int8_t* groups[4] = {p.left, p.right, p.intake, actuators};
  for (const int8_t* group : groups) {
    for (std::size_t i = 0; i < kMaxMotorsPerSide; ++i) {
      const int port = group[i] < 0 ? -group[i] : group[i];
      if (port == 0) continue;
      if (port > 21) return "motor port out of range 1..21";
      if (used[port]) return "a port is used twice";
      used[port] = true;
    }
  }
  if (p.left[0] == 0 || p.right[0] == 0) return "each drive side needs at least one motor";
  if (p.gps > 21) return "gps port out of range 1..21";
  if (p.gps != 0 && used[p.gps]) return "the gps port is also a motor port";
  if (p.imu > 21) return "imu port out of range 1..21";
  if (p.imu != 0 && (used[p.imu] || p.imu == p.gps)) return "the imu port is used by another device";
  if (p.radio > 21) return "radio port out of range 1..21";
  if (p.radio != 0 && (used[p.radio] || p.radio == p.gps || p.radio == p.imu)) {
    return "the radio port is used by another device";
  }
  if (p.radio != 0 && (p.link_id == nullptr || p.link_id[0] == '\0')) {
    return "a radio needs a link_id";
  }
  const int piston = adi_port_index(p.clamp_piston);
  const int sensor = adi_port_index(p.clamp_sensor);
  if (piston < 0 || sensor < 0) return "clamp ADI ports must be 0, 1..8 or 'A'..'H'";
  if (piston != 0 && piston == sensor) return "the clamp piston and sensor share an ADI port";
  if (piston != 0 && p.clamp_motor != 0) return "the clamp is a piston or a motor, not both";
  if (sensor != 0 && piston == 0 && p.clamp_motor == 0) return "a clamp sensor needs a clamp";
  const int lift = adi_port_index(p.lift_piston);
  if (lift < 0) return "lift_piston must be 0, 1..8 or 'A'..'H'";
  if (lift != 0 && (lift == piston || lift == sensor)) return "the lift piston shares an ADI port";
  if (lift != 0 && p.lift_motor != 0) return "the lift is a piston or a motor, not both";
  if (p.clamp_motor != 0 && !(p.clamp_motor_closed_deg != 0.0f)) {
    return "clamp_motor_closed_deg must not be 0 (the open angle)";
  }
  if (p.lift_motor != 0 && !(p.lift_motor_up_deg != 0.0f)) {
    return "lift_motor_up_deg must not be 0 (the lowered angle)";
  }
  if ((p.clamp_motor != 0 || p.lift_motor != 0) &&
      !(p.actuator_motor_rpm > 0.0f && p.actuator_motor_rpm <= 200.0f)) {
    return "actuator_motor_rpm must be in (0, 200]";
  }
  return nullptr;
}

static_assert(config_error(kRobotConfig) == nullptr, "kRobotConfig: see config_error()");
static_assert(ports_error(kRobotPorts) == nullptr, "kRobotPorts: see ports_error()");

}  // namespace pete::core
