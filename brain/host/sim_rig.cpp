#include "sim_rig.hpp"

#include <cstdio>

namespace pete::host {

namespace {

struct FaultName {
  msg::Fault bit;
  const char* name;
};

constexpr FaultName kFaultNames[] = {
    {msg::Fault::command_timeout, "command_timeout"},
    {msg::Fault::fingerprint_mismatch, "fingerprint_mismatch"},
    {msg::Fault::gps_fault, "gps_fault"},
    {msg::Fault::motor_fault, "motor_fault"},
    {msg::Fault::link_errors, "link_errors"},
    {msg::Fault::loop_overrun, "loop_overrun"},
};

}  // namespace

std::string fault_names(msg::Fault faults) {
  std::string out;
  for (const FaultName& f : kFaultNames) {
    if (!msg::has(faults, f.bit)) continue;
    if (!out.empty()) out += ',';
    out += f.name;
  }
  return out.empty() ? "none" : out;
}

SimRig::SimRig(const core::Config& config, core::SerialLink& serial, uint32_t boot_id)
    : robot(config,
            core::Hardware{clock, gps, imu, drive, intake, clamp, lift, serial, competition, driver, screen, radio},
            boot_id) {
  competition.status.connected = true;
}

bool SimRig::run_until(uint64_t t_ms) {
  if (t_ms < now_ms_) return false;
  const uint64_t period = robot.config().loop_period_ms;
  while (next_step_ms_ < t_ms) {
    clock.set_ms(next_step_ms_);
    robot.step();
    next_step_ms_ += period;
  }
  now_ms_ = t_ms;
  clock.set_ms(t_ms);
  return true;
}

bool SimRig::step_if_due(uint64_t now_ms) {
  if (now_ms < next_step_ms_) return false;
  const uint64_t period = robot.config().loop_period_ms;
  clock.set_ms(now_ms);
  robot.step();
  // Fixed cadence; if the host fell behind by whole periods, skip them rather than burst.
  next_step_ms_ += period;
  if (next_step_ms_ <= now_ms) next_step_ms_ = now_ms - (now_ms % period) + period;
  now_ms_ = now_ms;
  return true;
}

std::string SimRig::report() const {
  const core::RobotStatus& s = robot.status();
  const core::DriveModel& model = robot.model();
  const float left_rpm = drive.last.stop ? 0.0f : drive.last.left_rpm;
  const float right_rpm = drive.last.stop ? 0.0f : drive.last.right_rpm;
  char buf[900];
  std::snprintf(
      buf, sizeof buf,
      "t=%llu last_step_ms=%u phase=%s phase_ms=%u link=%s source=%s stopped=%d "
      "left_rpm=%.6g right_rpm=%.6g left_mps=%.6g right_mps=%.6g linear=%.6g angular=%.6g "
      "intake=%d rings=%u clamp=%u clamp_closed=%d lift_up=%d gps=%s faults=%s last_command_seq=%u "
      "steps=%u timeouts=%u pose=%s pose_x=%.6g pose_y=%.6g pose_heading=%.6g pose_std=%.6g "
      "period=%s match_ms=%u alliance=%s partner=%s",
      static_cast<unsigned long long>(now_ms_), s.state.time_ms, msg::to_string(s.phase),
      s.phase_ms, core::to_string(robot.link().state()), core::to_string(s.source),
      s.stopped ? 1 : 0,
      static_cast<double>(left_rpm), static_cast<double>(right_rpm),
      static_cast<double>(model.motor_rpm_to_wheel(left_rpm)),
      static_cast<double>(model.motor_rpm_to_wheel(right_rpm)),
      static_cast<double>(s.commanded.linear), static_cast<double>(s.commanded.angular),
      s.intake ? 1 : 0, static_cast<unsigned>(s.state.rings_held),
      static_cast<unsigned>(s.state.goal_clamped), s.clamp_closed ? 1 : 0, s.lift_up ? 1 : 0,
      msg::to_string(s.state.gps_status), fault_names(s.state.faults).c_str(),
      s.state.last_command_seq, s.steps, s.command_timeouts, msg::to_string(s.state.pose_fix),
      static_cast<double>(s.state.x), static_cast<double>(s.state.y),
      static_cast<double>(s.state.heading), static_cast<double>(s.state.pose_std),
      msg::to_string(s.state.period), s.state.match_ms, msg::to_string(s.state.alliance),
      msg::to_string(s.partner));
  return buf;
}

}  // namespace pete::host
