// Which alliance the robot plays for, found at run time rather than compiled in:
//
//   1. the V5 screen: the driver picks red or blue before the match (the PROS adapter's LLEMU
//      buttons; hal.hpp's AllianceInput). A pick stands until another pick replaces it, and
//      wins over everything else;
//   2. a fixed alliance in the configuration (Config::alliance), for a team that wants one;
//   3. the GPS start pose: the half of the field the robot stands in (red's half is on the side
//      of AllianceConfig::red_side_x_sign, as in the simulator's field file), while the robot
//      waits for the match and during the first lock_after_ms of it, and only from a pose the
//      GPS itself vouches for (pose_fix gps) at least center_margin_m from the centre line.
//      Once the match has run lock_after_ms the alliance stands for the rest of it (the robot
//      may cross into the other half); after the match it may be found again.
//
// Until one of them answers, the alliance is unknown and the Jetson does not drive.
#pragma once

#include <cstdint>

#include "pete/messages.hpp"

namespace pete::core {

struct AllianceConfig {
  float red_side_x_sign;    // -1: red's half of the field is x < 0 in the GPS frame
  float center_margin_m;    // a start pose closer than this to x = 0 says nothing
  uint32_t lock_after_ms;   // the match time after which the GPS no longer changes it
};

enum class AllianceSource : uint8_t { none, screen, config, gps };

const char* to_string(AllianceSource s);

class AllianceFinder {
 public:
  AllianceFinder(const AllianceConfig& config, msg::Alliance fixed)
      : config_(config), fixed_(fixed) {}

  /// One loop step. `screen`: the V5 screen's pick (unknown: none); `period` where the match is;
  /// `enabled_ms` how long the robot has been enabled in this match; `gps_fix` whether the pose
  /// rests on a GPS reading this step, and `x_m` its x. Returns true when the alliance changed.
  bool update(msg::Alliance screen, msg::MatchPeriod period, uint32_t enabled_ms, bool gps_fix,
              double x_m);

  msg::Alliance alliance() const { return alliance_; }
  AllianceSource source() const { return source_; }

 private:
  AllianceConfig config_;
  msg::Alliance fixed_;
  msg::Alliance alliance_ = msg::Alliance::unknown;
  AllianceSource source_ = AllianceSource::none;
};

}  // namespace pete::core
