// The Brain's end of the Brain <-> Jetson link: handshake, downlink decoding, what is sent when.
//
//   waiting    Hello every hello_period_ms; Commands are ignored.
//   connected  the Jetson's Hello carried our schema fingerprint: State every state_period_ms,
//              Commands are delivered. Every Hello the Jetson sends is answered with one Hello
//              (a restarted Jetson needs to see ours again); a new boot_id is reported.
//   mismatch   the Jetson's Hello carried another fingerprint: its Commands are never delivered,
//              Hello continues so the Jetson can diagnose it too, and a Log error names both
//              fingerprints (at most once a second). A later matching Hello connects.
// Logs queue (bounded) and go out a few per step in any state.
#pragma once

#include <cstddef>
#include <cstdint>

#include "pete/core/config.hpp"
#include "pete/core/hal.hpp"
#include "pete/core/text.hpp"
#include "pete/messages.hpp"

namespace pete::core {

/// Builds a Log's text: the field holds 48 bytes with no terminator required.
using LogText = Text<sizeof(msg::Log::text) + 1>;

enum class LinkState : uint8_t { waiting, connected, mismatch };

const char* to_string(LinkState s);

/// What one receive() found.
struct LinkInput {
  bool command = false;  // a Command was decoded and delivered (the newest one, if several)
  msg::Command cmd{};
  bool connected = false;       // a matching Hello arrived and the link was not connected to it
  bool peer_restarted = false;  // the Jetson's boot_id changed
  bool mismatch = false;        // a Hello with another schema's fingerprint arrived
  bool partner = false;         // the Jetson's report for the alliance partner (the newest)
  msg::Partner report{};
};

struct LinkCounters {
  uint32_t rx_bytes = 0;
  uint32_t packets_sent = 0;
  uint32_t tx_dropped = 0;       // packets the serial port refused
  uint32_t states_sent = 0;
  uint32_t hellos_sent = 0;
  uint32_t logs_sent = 0;
  uint32_t logs_dropped = 0;     // log queue full
  uint32_t commands = 0;         // Commands delivered
  uint32_t commands_ignored = 0; // Commands that arrived before a matching handshake
  uint32_t partner_reports = 0;  // the Jetson's reports for the partner, once connected
};

class Link {
 public:
  static constexpr std::size_t kLogQueue = 8;
  static constexpr std::size_t kMaxLogsPerStep = 2;
  /// Downlink bytes decoded per step at most, so a flood cannot stretch the control loop; the rest
  /// wait in the serial buffer for the next step.
  static constexpr std::size_t kMaxRxPerStep = 1024;
  static constexpr uint32_t kRepeatLogMs = 1000;

  Link(const LinkConfig& config, uint32_t boot_id, const char* software_version);

  /// Drain and decode what the Jetson sent since the last step.
  LinkInput receive(SerialLink& serial, uint32_t now_ms);
  /// Send what is due at now_ms: queued Logs, a Hello (while not connected, or in reply), and a
  /// State when one is due (its seq is filled in here).
  void transmit(SerialLink& serial, uint32_t now_ms, const msg::State& state);
  /// The partner's report and the partner link's state, for the Jetson (only once connected).
  bool send_partner(SerialLink& serial, const msg::Partner& theirs);
  bool send_partner_status(SerialLink& serial, const msg::PartnerStatus& status);
  /// Queue a Log (text cut to the field's 48 bytes). Dropped, and counted, when the queue is full.
  void log(msg::LogLevel level, uint32_t now_ms, const char* text);

  LinkState state() const { return state_; }
  bool connected() const { return state_ == LinkState::connected; }
  /// Downlink errors seen within the last second (for Fault::link_errors).
  bool recent_errors(uint32_t now_ms) const;
  const wire::ErrorCounters& errors() const { return decoder_.errors; }
  uint32_t lost() const { return decoder_.lost; }
  const LinkCounters& counters() const { return counters_; }
  uint32_t peer_fingerprint() const { return peer_fingerprint_; }
  uint32_t peer_boot_id() const { return peer_boot_id_; }

 private:
  void on_hello(const msg::Hello& hello, uint32_t now_ms, LinkInput& in);
  template <class M>
  bool send(SerialLink& serial, const M& m);

  LinkConfig config_;
  msg::Hello hello_{};
  msg::DownlinkDecoder decoder_;
  LinkState state_ = LinkState::waiting;
  LinkCounters counters_;

  uint8_t tx_seq_ = 0;
  uint32_t state_seq_ = 0;
  bool hello_started_ = false;
  uint32_t next_hello_ms_ = 0;
  bool hello_reply_ = false;
  bool state_started_ = false;
  uint32_t next_state_ms_ = 0;

  bool have_peer_ = false;
  uint32_t peer_fingerprint_ = 0;
  uint32_t peer_boot_id_ = 0;
  bool mismatch_logged_ = false;
  uint32_t mismatch_log_ms_ = 0;
  bool role_logged_ = false;
  uint32_t role_log_ms_ = 0;

  uint32_t errors_seen_ = 0;
  bool any_error_ = false;
  uint32_t last_error_ms_ = 0;
  uint32_t error_log_ms_ = 0;
  bool error_logged_ = false;

  msg::Log logs_[kLogQueue] = {};
  std::size_t log_head_ = 0;
  std::size_t log_count_ = 0;
};

}  // namespace pete::core
