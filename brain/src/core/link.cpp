#include "pete/core/link.hpp"

#include "pete/core/text.hpp"

namespace pete::core {

namespace {

// millis() wraps after 49 days; compare through a signed difference so scheduling survives it.
bool reached(uint32_t now_ms, uint32_t at_ms) {
  return static_cast<int32_t>(now_ms - at_ms) >= 0;
}

}  // namespace

const char* to_string(LinkState s) {
  switch (s) {
    case LinkState::waiting:
      return "waiting";
    case LinkState::connected:
      return "connected";
    case LinkState::mismatch:
      return "mismatch";
  }
  return "?";
}

Link::Link(const LinkConfig& config, uint32_t boot_id, const char* software_version)
    : config_(config) {
  hello_.fingerprint = msg::kFingerprint;
  hello_.protocol_version = msg::kProtocolVersion;
  hello_.role = msg::Role::brain;
  hello_.boot_id = boot_id;
  wire::set_text(hello_.software_version, software_version);
}

LinkInput Link::receive(SerialLink& serial, uint32_t now_ms) {
  LinkInput in;
  uint8_t chunk[64];
  msg::AnyMessage m;
  std::size_t budget = kMaxRxPerStep;
  while (budget > 0) {
    const std::size_t want = budget < sizeof chunk ? budget : sizeof chunk;
    const std::size_t n = serial.read(chunk, want);
    if (n == 0) break;
    budget -= n;
    counters_.rx_bytes += static_cast<uint32_t>(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (!decoder_.feed(chunk[i], m)) continue;
      if (m.id == msg::Hello::kId) {
        on_hello(m.hello, now_ms, in);
      } else if (m.id == msg::Command::kId) {
        if (state_ == LinkState::connected) {
          in.command = true;
          in.cmd = m.command;
          ++counters_.commands;
        } else {
          ++counters_.commands_ignored;
        }
      } else if (m.id == msg::Partner::kId && state_ == LinkState::connected) {
        in.partner = true;
        in.report = m.partner;
        ++counters_.partner_reports;
      }
    }
    if (n < want) break;
  }

  const uint32_t total = decoder_.errors.total();
  if (total != errors_seen_) {
    errors_seen_ = total;
    any_error_ = true;
    last_error_ms_ = now_ms;
    if (!error_logged_ || now_ms - error_log_ms_ >= kRepeatLogMs) {
      error_logged_ = true;
      error_log_ms_ = now_ms;
      LogText t;
      t.add("downlink errors: ").add_u32(total).add(" total");
      log(msg::LogLevel::warning, now_ms, t.c_str());
    }
  }
  return in;
}

void Link::on_hello(const msg::Hello& hello, uint32_t now_ms, LinkInput& in) {
  if (hello.role != msg::Role::jetson) {
    // Our own Hello looped back, or a second Brain: never a peer to drive for.
    if (!role_logged_ || now_ms - role_log_ms_ >= kRepeatLogMs) {
      role_logged_ = true;
      role_log_ms_ = now_ms;
      log(msg::LogLevel::warning, now_ms, "ignored a Hello whose role is not jetson");
    }
    return;
  }
  const bool restarted = have_peer_ && hello.boot_id != peer_boot_id_;
  have_peer_ = true;
  peer_fingerprint_ = hello.fingerprint;
  peer_boot_id_ = hello.boot_id;
  hello_reply_ = true;
  if (restarted) in.peer_restarted = true;

  if (hello.fingerprint != msg::kFingerprint) {
    in.mismatch = true;
    state_ = LinkState::mismatch;
    state_started_ = false;
    if (!mismatch_logged_ || now_ms - mismatch_log_ms_ >= kRepeatLogMs) {
      mismatch_logged_ = true;
      mismatch_log_ms_ = now_ms;
      // "fingerprint mismatch peer=XXXXXXXX ours=XXXXXXXX" is exactly the 48-byte field.
      LogText t;
      t.add("fingerprint mismatch peer=").add_hex32(hello.fingerprint);
      t.add(" ours=").add_hex32(msg::kFingerprint);
      log(msg::LogLevel::error, now_ms, t.c_str());
    }
    return;
  }
  if (state_ != LinkState::connected || restarted) {
    in.connected = true;
    LogText t;
    t.add("jetson connected, boot ").add_hex32(hello.boot_id);
    log(msg::LogLevel::info, now_ms, t.c_str());
  }
  if (state_ != LinkState::connected) {
    state_ = LinkState::connected;
    state_started_ = false;
  }
}

bool Link::recent_errors(uint32_t now_ms) const {
  return any_error_ && now_ms - last_error_ms_ < kRepeatLogMs;
}

void Link::log(msg::LogLevel level, uint32_t now_ms, const char* text) {
  if (log_count_ == kLogQueue) {
    // Keep the oldest: the first error of a cascade is the one that explains it.
    ++counters_.logs_dropped;
    return;
  }
  msg::Log& entry = logs_[(log_head_ + log_count_) % kLogQueue];
  entry.level = level;
  entry.time_ms = now_ms;
  wire::set_text(entry.text, text);
  ++log_count_;
}

bool Link::send_partner(SerialLink& serial, const msg::Partner& theirs) {
  return connected() && send(serial, theirs);
}

bool Link::send_partner_status(SerialLink& serial, const msg::PartnerStatus& status) {
  return connected() && send(serial, status);
}

template <class M>
bool Link::send(SerialLink& serial, const M& m) {
  uint8_t packet[msg::kMaxPacket];
  const std::size_t n = msg::encode_packet(m, tx_seq_, packet, sizeof packet);
  // The packet seq counts every packet, so the Jetson can count what the USB link lost.
  ++tx_seq_;
  ++counters_.packets_sent;
  if (n == 0 || !serial.write_packet(packet, n)) {
    ++counters_.tx_dropped;
    return false;
  }
  return true;
}

void Link::transmit(SerialLink& serial, uint32_t now_ms, const msg::State& state) {
  for (std::size_t i = 0; i < kMaxLogsPerStep && log_count_ > 0; ++i) {
    send(serial, logs_[log_head_]);
    log_head_ = (log_head_ + 1) % kLogQueue;
    --log_count_;
    ++counters_.logs_sent;
  }

  bool hello_due = hello_reply_;
  if (state_ != LinkState::connected) {
    if (!hello_started_ || reached(now_ms, next_hello_ms_)) hello_due = true;
  }
  if (hello_due) {
    hello_reply_ = false;
    hello_started_ = true;
    next_hello_ms_ = now_ms + config_.hello_period_ms;
    send(serial, hello_);
    ++counters_.hellos_sent;
  }

  if (state_ != LinkState::connected) return;
  if (state_started_ && !reached(now_ms, next_state_ms_)) return;
  // Keep the cadence fixed to the schedule, but never try to catch up a backlog in a burst.
  next_state_ms_ = state_started_ ? next_state_ms_ + config_.state_period_ms
                                  : now_ms + config_.state_period_ms;
  if (reached(now_ms, next_state_ms_)) next_state_ms_ = now_ms + config_.state_period_ms;
  state_started_ = true;
  msg::State out = state;
  out.seq = ++state_seq_;
  send(serial, out);
  ++counters_.states_sent;
}

}  // namespace pete::core
