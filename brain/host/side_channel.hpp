// brain_host's side channel: one text command per line in, one reply line out, through which a
// simulator plays the robot's hardware (GPS, competition switch, controller, motor feedback) and,
// in lockstep mode, owns the clock. brain/README.md ("brain_host") documents every command.
#pragma once

#include <cstdint>
#include <string>

#include "sim_rig.hpp"

namespace pete::host {

enum class Mode { lockstep, realtime };

/// The serial link as the side channel sees it: byte counters, and a way to wait for downlink
/// bytes the simulator knows it has written (what makes lockstep deterministic).
class LinkIo {
 public:
  /// Wait until at least `total` downlink bytes have been read; false on timeout or end of file.
  virtual bool wait_rx(uint64_t total, int timeout_ms) = 0;
  virtual uint64_t rx_total() const = 0;
  virtual uint64_t tx_total() const = 0;

 protected:
  ~LinkIo() = default;
};

class SideChannel {
 public:
  static constexpr int kRxWaitMs = 5000;
  /// One command runs at most an hour of loop steps, so a typo cannot hang the simulator.
  static constexpr uint64_t kMaxAdvanceMs = 3600000;

  SideChannel(SimRig& rig, Mode mode, LinkIo& io) : rig_(rig), mode_(mode), io_(io) {}

  /// Execute one command line; returns the reply line ("ok ..." or "error ..."), no newline.
  std::string handle(const std::string& line);
  bool quit() const { return quit_; }

 private:
  std::string run_to(uint64_t t_ms, const std::string& rx_arg);
  std::string report() const;

  SimRig& rig_;
  Mode mode_;
  LinkIo& io_;
  bool quit_ = false;
};

}  // namespace pete::host
