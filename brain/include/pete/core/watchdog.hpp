// The command watchdog: a Command is in force only inside its validity window, and only a NEW
// Command (different seq) renews it, so a replayed or stuck frame cannot keep the robot moving.
#pragma once

#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/messages.hpp"

namespace pete::core {

class CommandWatchdog {
 public:
  explicit CommandWatchdog(const LinkConfig& config) : config_(config) {}

  /// Take a Command received at now_ms. Returns false (and changes nothing) when its seq repeats
  /// the one in force. valid_ms = 0 means the configured default; longer than the configured
  /// maximum is cut to the maximum.
  bool accept(const msg::Command& command, uint32_t now_ms);
  /// True while the last accepted Command is inside its window: now < received + valid.
  bool active(uint32_t now_ms) const {
    return has_command_ && now_ms - received_ms_ < window_ms_;
  }
  /// Forget the Command in force (phase change, peer restart): the robot needs a new one to move.
  void clear() { has_command_ = false; }
  /// clear(), and forget the last seq too: a restarted Jetson numbers its Commands afresh.
  void forget_peer() {
    has_command_ = false;
    seen_any_ = false;
  }

  const msg::Command& command() const { return command_; }
  /// The window actually applied to the last accepted Command, after defaulting and clamping.
  uint32_t window_ms() const { return window_ms_; }

 private:
  LinkConfig config_;
  msg::Command command_{};
  uint32_t received_ms_ = 0;
  uint32_t window_ms_ = 0;
  bool has_command_ = false;
  bool seen_any_ = false;
};

}  // namespace pete::core
