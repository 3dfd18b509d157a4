// The Brain core on fake hardware, stepped on a simulated clock: what brain_host runs and what
// a simulator drives through the side channel (brain/README.md documents the protocol).
#pragma once

#include <cstdint>
#include <string>

#include "fakes.hpp"
#include "pete/core/config.hpp"
#include "pete/core/robot.hpp"

namespace pete::host {

class SimRig {
 public:
  SimRig(const core::Config& config, core::SerialLink& serial, uint32_t boot_id);

  /// Run every loop step scheduled before `t_ms` (steps fall at 0, period, 2 period, ...), each
  /// with the clock set to its own time, then leave the clock at t_ms. Earlier times are refused.
  bool run_until(uint64_t t_ms);
  /// Run the step due at the current time if it has not run yet (realtime mode).
  bool step_if_due(uint64_t now_ms);
  uint64_t now_ms() const { return now_ms_; }
  uint64_t next_step_ms() const { return next_step_ms_; }

  /// key=value summary of the last step, as the side channel reports it.
  std::string report() const;

  FakeClock clock;
  FakeGps gps;
  FakeImu imu;
  FakeDrivetrain drive;
  FakeIntake intake;
  FakeGoalClamp clamp;
  FakeLift lift;
  FakeCompetition competition;
  FakeDriverInput driver;
  FakeScreen screen;
  FakeRadio radio;
  core::Robot robot;

 private:
  uint64_t now_ms_ = 0;
  uint64_t next_step_ms_ = 0;
};

/// Faults as a comma-separated list of names ("none" when empty).
std::string fault_names(msg::Fault faults);

}  // namespace pete::host
