// The Brain's whole behaviour in one loop step, on top of the hardware interfaces: match clock,
// link, command watchdog, who-drives arbitration, drive limits, GPS checks, the goal clamp, and the
// State report.
// src/pros_adapter.cpp calls step() every loop_period_ms from its own task; brain_host and the
// tests call it with fake hardware and a fake clock.
#pragma once

#include <cstdint>

#include "pete/core/alliance.hpp"
#include "pete/core/arbiter.hpp"
#include "pete/core/clamp.hpp"
#include "pete/core/config.hpp"
#include "pete/core/drive.hpp"
#include "pete/core/hal.hpp"
#include "pete/core/lift.hpp"
#include "pete/core/link.hpp"
#include "pete/core/match_clock.hpp"
#include "pete/core/partner.hpp"
#include "pete/core/pose_filter.hpp"
#include "pete/core/watchdog.hpp"
#include "pete/messages.hpp"

namespace pete::core {

/// The GPS reading as the core will use it: an `ok` reading with non-finite or impossible
/// numbers becomes `error`, and any reading that is not `ok` carries zeros, never a stale or
/// invented pose. Heading is folded into [0, 360). The State's pose is the PoseFilter's, which
/// takes only `ok` readings.
GpsReading checked_gps(const GpsReading& raw);

/// Everything the last step decided, for brain_host's side channel and the tests.
struct RobotStatus {
  msg::MatchPhase phase = msg::MatchPhase::disabled;
  uint32_t phase_ms = 0;
  DriveSource source = DriveSource::none;
  Twist commanded;       // what the motors were told, as a twist
  WheelSpeeds wheels;    // ...as wheel surface speeds, m/s
  bool stopped = true;   // the motors were stopped (brake) rather than driven
  bool intake = false;
  bool clamp_closed = false;  // what the goal clamp was told
  bool lift_up = false;       // what the lift was told
  msg::PartnerLink partner = msg::PartnerLink::absent;  // the VEXlink partner link
  msg::State state;      // the State of this step (sent only when one is due)
  uint32_t steps = 0;
  uint32_t command_timeouts = 0;
  uint32_t overruns = 0;
  uint32_t last_step_us = 0;
  uint32_t max_step_us = 0;
};

class Robot {
 public:
  Robot(const Config& config, const Hardware& hw, uint32_t boot_id);

  /// One control-loop step. Call it every config.loop_period_ms.
  void step();

  const RobotStatus& status() const { return status_; }
  const Link& link() const { return link_; }
  const Config& config() const { return config_; }
  const DriveModel& model() const { return drive_.model(); }
  const PoseFilter& pose() const { return pose_; }
  const AllianceFinder& alliance() const { return alliance_; }
  const PartnerRelay& partner() const { return partner_; }

 private:
  void note_gps(msg::GpsStatus status, uint32_t now_ms);
  void note_pose(GpsUpdate update, uint32_t now_ms);
  msg::Fault faults(uint32_t now_ms, const GpsReading& gps, const WheelFeedback& fb) const;

  Config config_;
  Hardware hw_;
  uint32_t boot_id_;
  MatchClock match_;
  Link link_;
  CommandWatchdog watchdog_;
  Arbiter arbiter_;
  DriveController drive_;
  ClampControl clamp_;
  LiftControl lift_;
  PoseFilter pose_;
  AllianceFinder alliance_;
  PartnerRelay partner_;
  RobotStatus status_;

  bool started_ = false;
  uint32_t last_step_ms_ = 0;
  bool command_was_active_ = false;
  bool gps_known_ = false;
  msg::GpsStatus gps_status_ = msg::GpsStatus::absent;
  bool overrun_seen_ = false;
  uint32_t overrun_ms_ = 0;
  uint32_t overrun_log_ms_ = 0;
  uint32_t last_command_seq_ = 0;
  msg::MatchPeriod period_logged_ = msg::MatchPeriod::before;
  uint32_t reject_log_ms_ = 0;
  bool reject_logged_ = false;
  msg::PoseFix fix_logged_ = msg::PoseFix::lost;
  uint32_t enabled_ms_ = 0;  // time enabled in the current match
};

}  // namespace pete::core
