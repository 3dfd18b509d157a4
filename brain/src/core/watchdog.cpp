#include "pete/core/watchdog.hpp"

namespace pete::core {

bool CommandWatchdog::accept(const msg::Command& command, uint32_t now_ms) {
  // A repeat of the seq in force is stale, whether or not its window has run out: a Jetson that
  // stopped updating its commands must not be mistaken for a live one.
  if (seen_any_ && command.seq == command_.seq) return false;
  uint32_t window = command.valid_ms == 0 ? config_.default_command_valid_ms : command.valid_ms;
  if (window > config_.max_command_valid_ms) window = config_.max_command_valid_ms;
  command_ = command;
  received_ms_ = now_ms;
  window_ms_ = window;
  has_command_ = true;
  seen_any_ = true;
  return true;
}

}  // namespace pete::core
