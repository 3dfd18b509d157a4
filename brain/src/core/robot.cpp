#include "pete/core/robot.hpp"

#include <cmath>

#include "pete/core/text.hpp"
#include "pete/core/version.hpp"

namespace pete::core {

namespace {

// The GPS frame spans about +-1.8 m; a reading far outside the field is a sensor fault.
constexpr double kFieldLimitM = 2.5;
constexpr uint32_t kFaultHoldMs = 1000;

GpsReading cleared(msg::GpsStatus status) {
  GpsReading r;
  r.status = status;
  return r;
}

}  // namespace

GpsReading checked_gps(const GpsReading& raw) {
  if (raw.status != msg::GpsStatus::ok) return cleared(raw.status);
  if (!std::isfinite(raw.x_m) || !std::isfinite(raw.y_m) || !std::isfinite(raw.heading_deg) ||
      !std::isfinite(raw.error_m)) {
    return cleared(msg::GpsStatus::error);
  }
  if (std::fabs(raw.x_m) > kFieldLimitM || std::fabs(raw.y_m) > kFieldLimitM || raw.error_m < 0.0) {
    return cleared(msg::GpsStatus::error);
  }
  if (raw.heading_deg < -360.0 || raw.heading_deg > 720.0) return cleared(msg::GpsStatus::error);
  GpsReading out = raw;
  out.heading_deg = std::fmod(raw.heading_deg, 360.0);
  if (out.heading_deg < 0.0) out.heading_deg += 360.0;
  // fmod of a value just below 0 can round up to exactly 360.
  if (out.heading_deg >= 360.0) out.heading_deg = 0.0;
  return out;
}

Robot::Robot(const Config& config, const Hardware& hw, uint32_t boot_id)
    : config_(config),
      hw_(hw),
      boot_id_(boot_id),
      match_(config.match),
      link_(config.link, boot_id, kSoftwareVersion),
      watchdog_(config.link),
      arbiter_(config),
      drive_(config.drive),
      clamp_(config.clamp),
      pose_(config.pose),
      alliance_(config.find_alliance, config.alliance),
      partner_(config.partner) {}

void Robot::step() {
  const uint64_t t0_us = hw_.clock.now_us();
  const uint32_t now = hw_.clock.now_ms();
  const uint32_t period = config_.loop_period_ms;

  float dt_s = static_cast<float>(period) / 1000.0f;
  if (!started_) {
    LogText banner;
    banner.add("pete brain ").add(kSoftwareVersion).add(" boot ").add_hex32(boot_id_).add("\n");
    hw_.serial.write_text(banner.c_str(), banner.size());
  } else {
    const uint32_t gap = now - last_step_ms_;
    if (gap > period + period / 2) {
      overrun_seen_ = true;
      overrun_ms_ = now;
      ++status_.overruns;
      if (now - overrun_log_ms_ >= kFaultHoldMs || status_.overruns == 1) {
        overrun_log_ms_ = now;
        LogText t;
        t.add("loop overrun: ").add_u32(gap).add(" ms between steps");
        link_.log(msg::LogLevel::warning, now, t.c_str());
      }
    }
    // A late step may catch up a little, never by more than two periods at once.
    const uint32_t capped = gap < 2 * period ? gap : 2 * period;
    dt_s = static_cast<float>(capped) / 1000.0f;
  }
  started_ = true;
  last_step_ms_ = now;

  // Match phase. Every phase start drops the Command in force and any driver override: after a
  // (re-)enable the robot moves only on a Command that arrived in this phase.
  if (match_.update(hw_.competition.read(), now)) {
    watchdog_.clear();
    command_was_active_ = false;
    arbiter_.reset();
    LogText t;
    t.add("phase ").add(msg::to_string(match_.phase()));
    link_.log(msg::LogLevel::info, now, t.c_str());
    if (match_.match_began()) enabled_ms_ = 0;
    if (match_.period() != period_logged_ || match_.match_began()) {
      period_logged_ = match_.period();
      LogText m;
      m.add("period ").add(msg::to_string(match_.period()));
      if (match_.match_began()) m.add(", a new match");
      link_.log(msg::LogLevel::info, now, m.c_str());
    }
  }
  const msg::MatchPhase phase = match_.phase();

  // Link: decode what arrived; a Command renews the watchdog only if the link is connected.
  const LinkInput in = link_.receive(hw_.serial, now);
  if (in.peer_restarted || in.mismatch) {
    watchdog_.forget_peer();
    command_was_active_ = false;
  }
  if (in.command) watchdog_.accept(in.cmd, now);
  const bool command_active = link_.connected() && watchdog_.active(now);
  if (command_was_active_ && !command_active) {
    ++status_.command_timeouts;
    LogText t;
    t.add("command timeout: seq ").add_u32(watchdog_.command().seq).add(" expired after ");
    t.add_u32(watchdog_.window_ms()).add(" ms");
    link_.log(msg::LogLevel::warning, now, t.c_str());
  }
  command_was_active_ = command_active;

  const GpsReading gps = checked_gps(hw_.gps.read());
  note_gps(gps.status, now);

  // Who drives, then drive.
  const DriverSticks sticks = hw_.driver.read();
  const DriveSource source = arbiter_.decide(phase, command_active, sticks, now);
  bool intake = false;
  msg::ClampAction clamp_cmd = msg::ClampAction::leave;
  msg::LiftAction lift_cmd = msg::LiftAction::leave;
  switch (source) {
    case DriveSource::none:
      drive_.stop(hw_.drive);
      break;
    case DriveSource::jetson: {
      const msg::Command& cmd = watchdog_.command();
      drive_.drive({cmd.linear, cmd.angular}, dt_s, hw_.drive);
      intake = cmd.intake;
      clamp_cmd = cmd.clamp;
      lift_cmd = cmd.lift;
      last_command_seq_ = cmd.seq;
      break;
    }
    case DriveSource::driver:
      drive_.drive(arcade(sticks, config_.driver), dt_s, hw_.drive);
      intake = sticks.present && sticks.intake;
      break;
  }
  hw_.intake.set(intake);

  // The goal clamp: the Jetson's hold/release while it drives, the driver's L1, else auto close
  // on a goal at the back; it never opens by itself.
  const ClampEvent clamp_event = clamp_.update(phase, hw_.clamp.goal_at_back(),
                                               sticks.present && sticks.clamp, clamp_cmd, now);
  hw_.clamp.set(clamp_.closed());
  if (clamp_event != ClampEvent::none) link_.log(msg::LogLevel::info, now, to_string(clamp_event));
  const LiftEvent lift_event = lift_.update(phase, sticks.present && sticks.lift, lift_cmd);
  hw_.lift.set(lift_.up());
  if (lift_event != LiftEvent::none) link_.log(msg::LogLevel::info, now, to_string(lift_event));

  // The pose: odometry and the IMU every step, corrected by the GPS when it reads the strip.
  const WheelFeedback fb = hw_.drive.feedback();
  const DriveModel& model = drive_.model();
  const float left_speed =
      std::isfinite(fb.left_rpm) ? model.motor_rpm_to_wheel(fb.left_rpm) : 0.0f;
  const float right_speed =
      std::isfinite(fb.right_rpm) ? model.motor_rpm_to_wheel(fb.right_rpm) : 0.0f;
  const ImuReading imu = hw_.imu.read();
  const WheelSpeeds told = drive_.stopped() ? WheelSpeeds{} : model.wheels(drive_.commanded());
  pose_.commanded(static_cast<double>(told.left), static_cast<double>(told.right));
  pose_.predict(static_cast<double>(dt_s), static_cast<double>(left_speed),
                static_cast<double>(right_speed), imu.ok, imu.rotation_deg,
                static_cast<double>(config_.drive.track_width_m));
  if (gps.status == msg::GpsStatus::ok) note_pose(pose_.correct(gps.x_m, gps.y_m,
                                                                gps.heading_deg, gps.error_m, now),
                                                  now);
  const msg::PoseFix fix = pose_.fix(now);
  if (fix != fix_logged_) {
    fix_logged_ = fix;
    LogText t;
    t.add("pose ").add(msg::to_string(fix));
    link_.log(fix == msg::PoseFix::lost ? msg::LogLevel::warning : msg::LogLevel::info, now,
              t.c_str());
  }

  // The alliance: the V5 screen's pick, the configuration's, or the GPS start pose.
  if (phase != msg::MatchPhase::disabled) {
    enabled_ms_ += static_cast<uint32_t>(dt_s * 1000.0f + 0.5f);
  }
  if (alliance_.update(hw_.screen.read(), match_.period(), enabled_ms_,
                       fix == msg::PoseFix::gps, pose_.x())) {
    LogText t;
    t.add("alliance ").add(msg::to_string(alliance_.alliance()));
    if (alliance_.source() != AllianceSource::none) t.add(" from ").add(to_string(alliance_.source()));
    link_.log(msg::LogLevel::info, now, t.c_str());
  }

  // Report.
  msg::State& s = status_.state;
  s.time_ms = now;
  s.phase = phase;
  s.phase_ms = match_.phase_ms(now);
  s.alliance = alliance_.alliance();
  const bool posed = fix != msg::PoseFix::lost;
  s.x = posed ? static_cast<float>(pose_.x()) : 0.0f;
  s.y = posed ? static_cast<float>(pose_.y()) : 0.0f;
  s.heading = posed ? static_cast<float>(pose_.heading_deg()) : 0.0f;
  // float rounding can carry 359.99999 up to 360.0: fold it back.
  if (s.heading >= 360.0f) s.heading = 0.0f;
  s.pose_fix = fix;
  s.pose_std = posed ? static_cast<float>(pose_.position_std_m()) : 0.0f;
  s.heading_std = posed ? static_cast<float>(pose_.heading_std_deg()) : 0.0f;
  s.gps_error = static_cast<float>(gps.error_m);
  s.gps_status = gps.status;
  s.left_speed = left_speed;
  s.right_speed = right_speed;
  s.last_command_seq = last_command_seq_;
  s.rings_held = hw_.intake.rings_held();
  s.goal_clamped = clamp_.goal_clamped();
  s.faults = faults(now, gps, fb);
  s.period = match_.period();
  s.match_ms = match_.match_ms(now);
  s.clamp = !hw_.clamp.fitted() ? msg::ClampState::absent
            : clamp_.closed()   ? msg::ClampState::closed
                                : msg::ClampState::open;
  s.lift = !hw_.lift.fitted() ? msg::LiftState::absent
           : lift_.up()       ? msg::LiftState::up
                              : msg::LiftState::down;
  link_.transmit(hw_.serial, now, s);

  // The partner link: our Jetson's newest report out over VEXlink, the partner's in to our Jetson.
  if (in.partner) partner_.report(in.report, now);
  msg::Partner theirs{};
  if (partner_.step(hw_.radio, now, theirs)) link_.send_partner(hw_.serial, theirs);
  if (partner_.changed()) {
    LogText t;
    t.add("partner link ").add(msg::to_string(partner_.link()));
    if (partner_.link() == msg::PartnerLink::lost) t.add(": playing alone");
    const bool bad = partner_.link() == msg::PartnerLink::lost;
    link_.log(bad ? msg::LogLevel::warning : msg::LogLevel::info, now, t.c_str());
  }
  if (partner_.status_due(now)) link_.send_partner_status(hw_.serial, partner_.status(now));
  status_.partner = partner_.link();

  status_.phase = phase;
  status_.phase_ms = s.phase_ms;
  status_.source = source;
  status_.commanded = drive_.commanded();
  status_.wheels = model.wheels(status_.commanded);
  status_.stopped = drive_.stopped();
  status_.intake = intake;
  status_.clamp_closed = clamp_.closed();
  status_.lift_up = lift_.up();
  ++status_.steps;

  const uint64_t took = hw_.clock.now_us() - t0_us;
  status_.last_step_us = took > 0xFFFFFFFFu ? 0xFFFFFFFFu : static_cast<uint32_t>(took);
  if (status_.last_step_us > status_.max_step_us) status_.max_step_us = status_.last_step_us;
  if (took > uint64_t{period} * 1000u) {
    overrun_seen_ = true;
    overrun_ms_ = now;
    ++status_.overruns;
  }
}

void Robot::note_pose(GpsUpdate update, uint32_t now_ms) {
  switch (update) {
    case GpsUpdate::none:
    case GpsUpdate::accepted:
      return;
    case GpsUpdate::rejected:
      // A jump can last several readings: one line a second is enough.
      if (reject_logged_ && now_ms - reject_log_ms_ < kFaultHoldMs) return;
      reject_logged_ = true;
      reject_log_ms_ = now_ms;
      link_.log(msg::LogLevel::warning, now_ms, to_string(update));
      return;
    case GpsUpdate::initialised:
    case GpsUpdate::reanchored:
      link_.log(update == GpsUpdate::reanchored ? msg::LogLevel::warning : msg::LogLevel::info,
                now_ms, to_string(update));
      return;
  }
}

void Robot::note_gps(msg::GpsStatus status, uint32_t now_ms) {
  if (gps_known_ && status == gps_status_) return;
  gps_known_ = true;
  gps_status_ = status;
  LogText t;
  t.add("gps ").add(msg::to_string(status));
  link_.log(status == msg::GpsStatus::ok ? msg::LogLevel::info : msg::LogLevel::warning, now_ms,
            t.c_str());
}

msg::Fault Robot::faults(uint32_t now_ms, const GpsReading& gps, const WheelFeedback& fb) const {
  msg::Fault f{};
  if (!(link_.connected() && watchdog_.active(now_ms))) f |= msg::Fault::command_timeout;
  if (link_.state() == LinkState::mismatch) f |= msg::Fault::fingerprint_mismatch;
  if (gps.status != msg::GpsStatus::ok) f |= msg::Fault::gps_fault;
  if (fb.fault) f |= msg::Fault::motor_fault;
  if (link_.recent_errors(now_ms)) f |= msg::Fault::link_errors;
  if (overrun_seen_ && now_ms - overrun_ms_ < kFaultHoldMs) f |= msg::Fault::loop_overrun;
  return f;
}

}  // namespace pete::core
