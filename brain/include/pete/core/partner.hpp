// The partner link: our Jetson's reports to the alliance partner go out over VEXlink, the
// partner's come back and go to our Jetson unchanged.
//
//   absent      no radio configured for the link.
//   connecting  a radio, but no partner report has arrived yet (VEXlink takes 1-2 s to come up).
//   up          a partner report arrived within timeout_ms.
//   lost        none since, or the radio lost the partner's. Losing the partner is normal: each
//               robot plays on alone, and the Jetson hears it in PartnerStatus.
//
// Only the newest report of ours is kept and it goes out at most every period_ms, so a slow or
// busy radio never builds a queue of old positions; a report older than report_max_age_ms (our
// Jetson went quiet) is not sent at all. Radio bytes are COBS frames of ordinary packets
// (wire::cobs_frame), checked by their CRC; anything but a Partner is counted as an error.
#pragma once

#include <cstddef>
#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/messages.hpp"
#include "pete/wire.hpp"

namespace pete::core {

class PartnerRelay {
 public:
  /// Radio bytes decoded per step at most, so a flood cannot stretch the control loop.
  static constexpr std::size_t kMaxRxPerStep = 512;

  explicit PartnerRelay(const PartnerConfig& config) : config_(config) {}

  /// Our Jetson's newest report; it replaces one not yet sent.
  void report(const msg::Partner& ours, uint32_t now_ms);
  /// Send our report if one is due, read what the radio brought. True, with `theirs` set to the
  /// newest, when partner reports arrived this step.
  bool step(Radio& radio, uint32_t now_ms, msg::Partner& theirs);

  msg::PartnerLink link() const { return link_; }
  /// True when a PartnerStatus is due: every status_period_ms, and at once when the link's state
  /// changed. Read changed() (and previous()) before it: it clears the change.
  bool status_due(uint32_t now_ms);
  bool changed() const { return changed_; }
  msg::PartnerLink previous() const { return previous_; }
  msg::PartnerStatus status(uint32_t now_ms) const;
  const wire::ErrorCounters& errors() const { return errors_; }

 private:
  void update_link(Radio& radio, uint32_t now_ms);

  PartnerConfig config_;
  msg::Partner ours_{};
  bool have_ours_ = false;
  uint32_t ours_ms_ = 0;
  bool sent_once_ = false;
  uint32_t last_tx_ms_ = 0;
  uint8_t tx_seq_ = 0;

  wire::CobsAssembler frames_;
  wire::SeqTracker seq_;
  wire::ErrorCounters errors_;
  bool heard_ = false;
  uint32_t last_rx_ms_ = 0;

  msg::PartnerLink link_ = msg::PartnerLink::absent;
  msg::PartnerLink previous_ = msg::PartnerLink::absent;
  bool changed_ = true;  // the first status goes out at once
  bool status_started_ = false;
  uint32_t next_status_ms_ = 0;

  uint32_t received_ = 0;
  uint32_t sent_ = 0;
  uint32_t busy_ = 0;
  uint32_t lost_ = 0;
};

}  // namespace pete::core
