// Shared helpers for the Brain core tests: downlink lines as the Jetson would send them, and a
// rig of fake hardware around the core with an in-memory serial link.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fakes.hpp"
#include "pete/core/config.hpp"
#include "pete/messages.hpp"
#include "sim_rig.hpp"

namespace pete::test {

inline std::string downlink(const msg::Hello& m, uint8_t seq = 0) {
  char buf[msg::kMaxDownlinkLine];
  return std::string(buf, msg::encode_downlink(m, seq, buf, sizeof buf));
}

inline std::string downlink(const msg::Command& m, uint8_t seq = 0) {
  char buf[msg::kMaxDownlinkLine];
  return std::string(buf, msg::encode_downlink(m, seq, buf, sizeof buf));
}

inline msg::Hello jetson_hello(uint32_t fingerprint = msg::kFingerprint,
                               uint32_t boot_id = 0xA11CE) {
  msg::Hello h;
  h.fingerprint = fingerprint;
  h.protocol_version = msg::kProtocolVersion;
  h.role = msg::Role::jetson;
  h.boot_id = boot_id;
  wire::set_text(h.software_version, "test");
  return h;
}

inline msg::Command command(uint32_t seq, float linear, float angular, uint16_t valid_ms = 250,
                            bool intake = false) {
  msg::Command c;
  c.seq = seq;
  c.linear = linear;
  c.angular = angular;
  c.intake = intake;
  c.valid_ms = valid_ms;
  return c;
}

inline std::string downlink(const msg::Partner& m, uint8_t seq = 0) {
  char buf[msg::kMaxDownlinkLine];
  return std::string(buf, msg::encode_downlink(m, seq, buf, sizeof buf));
}

/// One partner report as a radio frame: COBS(packet) || 0x00.
inline std::vector<uint8_t> radio_frame(const msg::Partner& m, uint8_t seq = 0) {
  uint8_t packet[msg::kMaxPacket];
  uint8_t frame[msg::kMaxPacket + 4];
  const std::size_t n = msg::encode_packet(m, seq, packet, sizeof packet);
  const std::size_t k = wire::cobs_frame(packet, n, frame, sizeof frame);
  return std::vector<uint8_t>(frame, frame + k);
}

template <class M>
std::vector<M> only(const std::vector<msg::AnyMessage>& all) {
  std::vector<M> out;
  for (const auto& m : all) {
    if (m.id != M::kId) continue;
    if constexpr (M::kId == msg::Hello::kId) out.push_back(m.hello);
    if constexpr (M::kId == msg::State::kId) out.push_back(m.state);
    if constexpr (M::kId == msg::Log::kId) out.push_back(m.log);
    if constexpr (M::kId == msg::Partner::kId) out.push_back(m.partner);
    if constexpr (M::kId == msg::PartnerStatus::kId) out.push_back(m.partnerstatus);
  }
  return out;
}

/// The core on fake hardware with an in-memory serial link; time moves only when the test says.
struct Rig {
  explicit Rig(const core::Config& config = core::kRobotConfig, uint32_t boot_id = 0x12345678)
      : sim(config, serial, boot_id) {}

  /// Run the loop up to (not including) `ms` from now.
  void run(uint64_t ms) { sim.run_until(sim.now_ms() + ms); }
  void send(const std::string& line) { serial.push_rx(line); }
  void handshake() {
    send(downlink(jetson_hello()));
    run(sim.robot.config().loop_period_ms);
  }
  const core::RobotStatus& status() const { return sim.robot.status(); }
  const host::DriveCall& motors() const { return sim.drive.last; }

  host::MemorySerial serial;
  host::SimRig sim;
};

}  // namespace pete::test
