#include "side_channel.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

namespace pete::host {

namespace {

constexpr const char* kHelp =
    "ok commands: get | advance MS [rx=BYTES] | until MS [rx=BYTES] | "
    "phase disabled|autonomous|driver | gps X Y HEADING [ERROR] | "
    "gps calibrating|error|absent | sticks FORWARD TURN [intake] [clamp] [lift] | sticks off | "
    "measured LEFT_MPS RIGHT_MPS | measured auto | imu ROTATION_DEG | imu off | "
    "screen red|blue|none | "
    "rings N|unknown | clamp 0|1|unknown | "
    "motor_fault 0|1 | radio off|on|unlinked | radio rx HEX | radio tx | help | quit";

std::vector<std::string> split(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string tok; in >> tok;) out.push_back(tok);
  return out;
}

bool parse_number(const std::string& s, double& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (errno != 0 || end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  out = v;
  return true;
}

bool parse_hex(const std::string& s, std::vector<uint8_t>& out) {
  if (s.size() % 2 != 0) return false;
  auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  out.clear();
  for (std::size_t i = 0; i < s.size(); i += 2) {
    const int hi = nibble(s[i]), lo = nibble(s[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out.push_back(static_cast<uint8_t>((hi << 4) | lo));
  }
  return true;
}

bool parse_count(const std::string& s, uint64_t& out) {
  if (s.empty() || s[0] < '0' || s[0] > '9') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(s.c_str(), &end, 10);
  if (errno != 0 || end != s.c_str() + s.size()) return false;
  out = v;
  return true;
}

std::string error(const std::string& what) { return "error " + what; }

std::string not_number(const std::string& cmd, const std::string& tok) {
  return error(cmd + ": '" + tok + "' is not a finite number");
}

}  // namespace

std::string SideChannel::report() const {
  return "ok " + rig_.report() + " rx=" + std::to_string(io_.rx_total()) +
         " tx=" + std::to_string(io_.tx_total());
}

std::string SideChannel::run_to(uint64_t t_ms, const std::string& rx_arg) {
  if (mode_ != Mode::lockstep) {
    return error("advance/until need --lockstep (in --realtime the wall clock runs the loop)");
  }
  if (t_ms < rig_.now_ms()) {
    return error("time " + std::to_string(t_ms) + " is before now (" +
                 std::to_string(rig_.now_ms()) + "): the clock only moves forward");
  }
  if (!rx_arg.empty()) {
    uint64_t want = 0;
    if (rx_arg.rfind("rx=", 0) != 0 || !parse_count(rx_arg.substr(3), want)) {
      return error("expected rx=BYTES, got '" + rx_arg + "'");
    }
    if (!io_.wait_rx(want, kRxWaitMs)) {
      return error("timed out waiting for downlink bytes: have " + std::to_string(io_.rx_total()) +
                   ", want " + std::to_string(want));
    }
  } else {
    io_.wait_rx(0, 0);  // take whatever has already arrived
  }
  rig_.run_until(t_ms);
  return report();
}

std::string SideChannel::handle(const std::string& line) {
  const std::vector<std::string> t = split(line);
  if (t.empty()) return error("empty command (try: help)");
  const std::string& cmd = t[0];
  const std::size_t n = t.size();

  if (cmd == "help") return kHelp;
  if (cmd == "quit") {
    quit_ = true;
    return "ok bye";
  }
  if (cmd == "get") {
    if (n != 1) return error("get takes no arguments");
    return report();
  }
  if (cmd == "advance" || cmd == "until") {
    if (n < 2 || n > 3) return error(cmd + " MS [rx=BYTES]");
    uint64_t ms = 0;
    if (!parse_count(t[1], ms)) return error(cmd + ": '" + t[1] + "' is not a whole number of ms");
    const bool too_far = cmd == "advance" ? ms > kMaxAdvanceMs : ms > rig_.now_ms() + kMaxAdvanceMs;
    if (too_far) {
      return error(cmd + ": at most " + std::to_string(kMaxAdvanceMs) + " ms per command");
    }
    const uint64_t target = cmd == "advance" ? rig_.now_ms() + ms : ms;
    return run_to(target, n == 3 ? t[2] : std::string());
  }
  if (cmd == "phase") {
    if (n != 2) return error("phase disabled|autonomous|driver");
    if (t[1] == "disabled") {
      rig_.competition.set_phase(msg::MatchPhase::disabled);
    } else if (t[1] == "autonomous") {
      rig_.competition.set_phase(msg::MatchPhase::autonomous);
    } else if (t[1] == "driver") {
      rig_.competition.set_phase(msg::MatchPhase::driver);
    } else {
      return error("phase: '" + t[1] + "' is not disabled, autonomous or driver");
    }
    return "ok";
  }
  if (cmd == "gps") {
    if (n == 2) {
      if (t[1] == "calibrating") {
        rig_.gps.set_status(msg::GpsStatus::calibrating);
      } else if (t[1] == "error") {
        rig_.gps.set_status(msg::GpsStatus::error);
      } else if (t[1] == "absent") {
        rig_.gps.set_status(msg::GpsStatus::absent);
      } else {
        return error("gps: '" + t[1] + "' is not calibrating, error or absent");
      }
      return "ok";
    }
    if (n != 4 && n != 5) return error("gps X Y HEADING [ERROR] | gps calibrating|error|absent");
    double v[4] = {0.0, 0.0, 0.0, 0.01};
    for (std::size_t i = 1; i < n; ++i) {
      if (!parse_number(t[i], v[i - 1])) return not_number("gps", t[i]);
    }
    rig_.gps.set_pose(v[0], v[1], v[2], v[3]);
    return "ok";
  }
  if (cmd == "sticks") {
    if (n == 2 && t[1] == "off") {
      rig_.driver.sticks = {};
      return "ok";
    }
    if (n < 3 || n > 6) return error("sticks FORWARD TURN [intake] [clamp] [lift] | sticks off");
    double f = 0.0, r = 0.0;
    if (!parse_number(t[1], f)) return not_number("sticks", t[1]);
    if (!parse_number(t[2], r)) return not_number("sticks", t[2]);
    if (std::fabs(f) > 1.0 || std::fabs(r) > 1.0) return error("sticks: axes must be in [-1, 1]");
    bool intake = false, clamp = false, lift = false;
    for (std::size_t i = 3; i < n; ++i) {
      bool& button = t[i] == "intake" ? intake : t[i] == "clamp" ? clamp : lift;
      if ((t[i] != "intake" && t[i] != "clamp" && t[i] != "lift") || button) {
        return error("sticks: '" + t[i] +
                     "' should be 'intake', 'clamp' or 'lift', each at most once");
      }
      button = true;
    }
    rig_.driver.sticks = {true, static_cast<float>(f), static_cast<float>(r), intake, clamp, lift};
    return "ok";
  }
  if (cmd == "measured") {
    if (n == 2 && t[1] == "auto") {
      rig_.drive.measured_override = false;
      return "ok";
    }
    if (n != 3) return error("measured LEFT_MPS RIGHT_MPS | measured auto");
    double l = 0.0, r = 0.0;
    if (!parse_number(t[1], l)) return not_number("measured", t[1]);
    if (!parse_number(t[2], r)) return not_number("measured", t[2]);
    const core::DriveModel& model = rig_.robot.model();
    rig_.drive.measured_override = true;
    rig_.drive.measured.left_rpm = model.wheel_to_motor_rpm(static_cast<float>(l));
    rig_.drive.measured.right_rpm = model.wheel_to_motor_rpm(static_cast<float>(r));
    return "ok";
  }
  if (cmd == "screen") {
    // The alliance the driver picks on the V5 screen (none: no pick, the GPS start pose decides).
    if (n != 2 || (t[1] != "red" && t[1] != "blue" && t[1] != "none")) {
      return error("screen red|blue|none");
    }
    rig_.screen.pick = t[1] == "red"    ? msg::Alliance::red
                       : t[1] == "blue" ? msg::Alliance::blue
                                        : msg::Alliance::unknown;
    return "ok";
  }
  if (cmd == "imu") {
    // The inertial sensor's cumulative clockwise rotation, or none (unplugged, calibrating).
    if (n == 2 && t[1] == "off") {
      rig_.imu.reading = {};
      return "ok";
    }
    double deg = 0.0;
    if (n != 2) return error("imu ROTATION_DEG | imu off");
    if (!parse_number(t[1], deg)) return not_number("imu", t[1]);
    rig_.imu.set_rotation(deg);
    return "ok";
  }
  if (cmd == "rings") {
    if (n == 2 && t[1] == "unknown") {
      rig_.intake.rings = core::kRingsUnknown;
      return "ok";
    }
    double count = 0.0;
    if (n != 2 || !parse_number(t[1], count) || count < 0.0 || count > 254.0 ||
        count != static_cast<double>(static_cast<int>(count))) {
      return error("rings N (0..254) | rings unknown");
    }
    rig_.intake.rings = static_cast<uint8_t>(count);
    return "ok";
  }
  if (cmd == "clamp") {
    // The switch at the clamp's mouth: a goal is (1) or is not (0) at the back, or no sensor.
    if (n != 2 || (t[1] != "0" && t[1] != "1" && t[1] != "unknown")) {
      return error("clamp 0|1|unknown");
    }
    rig_.clamp.sensor = t[1] == "unknown" ? core::kClampUnknown : (t[1] == "1" ? 1 : 0);
    return "ok";
  }
  if (cmd == "radio") {
    // The VEXlink radio: fitted or not, linked to the partner's or not; the partner's bytes in
    // (as the simulator's radio model delivers them) and this Brain's bytes out.
    FakeRadio& radio = rig_.radio;
    if (n == 2 && (t[1] == "off" || t[1] == "on" || t[1] == "unlinked")) {
      radio.is_fitted = t[1] != "off";
      radio.linked = t[1] == "on";
      return "ok";
    }
    if (n == 3 && t[1] == "rx") {
      std::vector<uint8_t> bytes;
      if (!parse_hex(t[2], bytes)) return error("radio rx: '" + t[2] + "' is not hex bytes");
      if (!radio.connected()) return "ok delivered=0";  // no link: the bytes never arrive
      radio.rx.insert(radio.rx.end(), bytes.begin(), bytes.end());
      return "ok delivered=1";
    }
    if (n == 2 && t[1] == "tx") {
      static constexpr char kHex[] = "0123456789abcdef";
      std::string out = "ok bytes=";
      for (uint8_t b : radio.sent) {
        out += kHex[b >> 4];
        out += kHex[b & 0x0F];
      }
      if (radio.sent.empty()) out += "-";
      radio.sent.clear();
      return out;
    }
    return error("radio off|on|unlinked | radio rx HEX | radio tx");
  }
  if (cmd == "motor_fault") {
    if (n != 2 || (t[1] != "0" && t[1] != "1")) return error("motor_fault 0|1");
    rig_.drive.fault = t[1] == "1";
    rig_.drive.measured.fault = rig_.drive.fault;
    return "ok";
  }
  return error("unknown command '" + cmd + "' (try: help)");
}

}  // namespace pete::host
