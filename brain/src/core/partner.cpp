#include "pete/core/partner.hpp"

namespace pete::core {

void PartnerRelay::report(const msg::Partner& ours, uint32_t now_ms) {
  ours_ = ours;
  have_ours_ = true;
  ours_ms_ = now_ms;
}

bool PartnerRelay::step(Radio& radio, uint32_t now_ms, msg::Partner& theirs) {
  bool got = false;
  if (radio.fitted()) {
    uint8_t chunk[64];
    std::size_t budget = kMaxRxPerStep;
    msg::AnyMessage m;
    while (budget > 0) {
      const std::size_t want = budget < sizeof chunk ? budget : sizeof chunk;
      const std::size_t n = radio.read(chunk, want);
      if (n == 0) break;
      budget -= n;
      for (std::size_t i = 0; i < n; ++i) {
        if (!frames_.feed(chunk[i], errors_)) continue;
        wire::Error err{};
        if (!msg::decode_packet(frames_.packet(), frames_.size(), m, err)) {
          errors_.add(err);
          continue;
        }
        if (m.id != msg::Partner::kId) {
          errors_.add(wire::Error::wrong_direction);
          continue;
        }
        lost_ += seq_.observe(m.seq);
        ++received_;
        theirs = m.partner;
        got = true;
        heard_ = true;
        last_rx_ms_ = now_ms;
      }
      if (n < want) break;
    }

    const bool due = !sent_once_ || now_ms - last_tx_ms_ >= config_.period_ms;
    const bool fresh = have_ours_ && now_ms - ours_ms_ <= config_.report_max_age_ms;
    if (due && fresh && radio.connected()) {
      uint8_t packet[msg::kMaxPacket];
      uint8_t frame[msg::kMaxPacket + msg::kMaxPacket / 254 + 2];
      const std::size_t n = msg::encode_packet(ours_, tx_seq_, packet, sizeof packet);
      const std::size_t k = n == 0 ? 0 : wire::cobs_frame(packet, n, frame, sizeof frame);
      if (k != 0 && radio.write(frame, k)) {
        ++tx_seq_;
        ++sent_;
        have_ours_ = false;  // sent: the next one is the Jetson's next report
        sent_once_ = true;
        last_tx_ms_ = now_ms;
      } else {
        ++busy_;  // kept: it goes when the radio has room, unless a newer one replaces it
      }
    }
  }
  update_link(radio, now_ms);
  return got;
}

void PartnerRelay::update_link(Radio& radio, uint32_t now_ms) {
  msg::PartnerLink next;
  if (!radio.fitted()) {
    next = msg::PartnerLink::absent;
  } else if (!heard_) {
    next = msg::PartnerLink::connecting;
  } else if (radio.connected() && now_ms - last_rx_ms_ < config_.timeout_ms) {
    next = msg::PartnerLink::up;
  } else {
    next = msg::PartnerLink::lost;
  }
  if (next != link_) {
    previous_ = link_;
    link_ = next;
    changed_ = true;
  }
}

bool PartnerRelay::status_due(uint32_t now_ms) {
  const bool periodic = !status_started_ || now_ms - next_status_ms_ < 0x80000000u;
  if (!changed_ && !periodic) return false;
  status_started_ = true;
  next_status_ms_ = now_ms + config_.status_period_ms;
  changed_ = false;
  return true;
}

msg::PartnerStatus PartnerRelay::status(uint32_t now_ms) const {
  msg::PartnerStatus s;
  s.link = link_;
  const uint32_t age = now_ms - last_rx_ms_;
  s.age_ms = !heard_ || age >= 0xFFFFu ? 0xFFFFu : static_cast<uint16_t>(age);
  s.received = received_;
  s.sent = sent_;
  s.busy = busy_;
  s.lost = lost_;
  s.errors = errors_.total();
  return s;
}

}  // namespace pete::core
