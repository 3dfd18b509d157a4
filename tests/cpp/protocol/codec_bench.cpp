// pete_codec_bench: how long the C++ codec takes per frame, on the host, optimised and without
// sanitizers. Prints one JSON object (ns per frame, medians over repeated batches); bench/protocol.py
// runs it and records the result.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "pete/messages.hpp"
#include "pete/wire.hpp"

namespace {

using Clock = std::chrono::steady_clock;

// Makes the compiler assume `p` is read and written here, so work on it cannot be hoisted or dropped.
inline void clobber(const void* p) { __asm__ __volatile__("" : : "r"(p) : "memory"); }

constexpr int kBatches = 31;
constexpr double kBatchSeconds = 0.004;

// Median ns per call of `op` (called with the iteration number). Each batch is sized to take about
// kBatchSeconds, so timer resolution and loop overhead are negligible.
template <class Op>
double median_ns(Op op) {
  uint32_t iters = 1;
  for (;;) {
    const auto t0 = Clock::now();
    for (uint32_t i = 0; i < iters; ++i) op(i);
    const std::chrono::duration<double> dt = Clock::now() - t0;
    if (dt.count() >= kBatchSeconds / 4 || iters >= (1u << 28)) {
      const double per = dt.count() / iters;
      iters = std::max<uint32_t>(1, static_cast<uint32_t>(kBatchSeconds / std::max(per, 1e-12)));
      break;
    }
    iters *= 2;
  }
  std::vector<double> ns;
  for (int b = 0; b < kBatches; ++b) {
    const auto t0 = Clock::now();
    for (uint32_t i = 0; i < iters; ++i) op(i);
    const std::chrono::duration<double, std::nano> dt = Clock::now() - t0;
    ns.push_back(dt.count() / iters);
  }
  std::nth_element(ns.begin(), ns.begin() + kBatches / 2, ns.end());
  return ns[kBatches / 2];
}

pete::msg::State sample_state() {
  pete::msg::State s;
  s.seq = 1042;
  s.time_ms = 61234;
  s.phase = pete::msg::MatchPhase::autonomous;
  s.phase_ms = 4250;
  s.alliance = pete::msg::Alliance::red;
  s.x = 0.5f;
  s.y = -1.25f;
  s.heading = 270.5f;
  s.gps_error = 0.0125f;
  s.left_speed = 0.61f;
  s.right_speed = -0.3f;
  s.last_command_seq = 977;
  s.faults = pete::msg::Fault::gps_fault;
  return s;
}

pete::msg::Command sample_command() {
  pete::msg::Command c;
  c.seq = 977;
  c.linear = 0.61f;
  c.angular = -4.83f;
  c.intake = true;
  c.valid_ms = 250;
  return c;
}

}  // namespace

int main() {
  const pete::msg::State state = sample_state();
  const pete::msg::Command command = sample_command();

  char line[pete::msg::kMaxDownlinkLine];
  const std::size_t line_len = pete::msg::encode_downlink(command, 7, line, sizeof line);
  uint8_t packet[pete::msg::kMaxPacket];
  const std::size_t packet_len = pete::msg::encode_packet(state, 42, packet, sizeof packet);
  if (line_len == 0 || packet_len == 0) {
    std::fprintf(stderr, "pete_codec_bench: could not encode the sample messages\n");
    return 1;
  }

  // Every timed operation must also be correct, or the numbers mean nothing.
  uint32_t failures = 0;

  pete::msg::DownlinkDecoder dec;
  pete::msg::AnyMessage rx;
  const double downlink_decode = median_ns([&](uint32_t) {
    clobber(line);
    bool got = false;
    for (std::size_t k = 0; k < line_len; ++k) got = dec.feed(static_cast<uint8_t>(line[k]), rx);
    failures += got ? 0u : 1u;
    clobber(&rx);
  });

  const double packet_decode = median_ns([&](uint32_t) {
    clobber(packet);
    pete::wire::Error err{};
    failures += pete::msg::decode_packet(packet, packet_len, rx, err) ? 0u : 1u;
    clobber(&rx);
  });

  uint8_t out[pete::msg::kMaxPacket];
  const double packet_encode = median_ns([&](uint32_t i) {
    clobber(&state);
    failures += pete::msg::encode_packet(state, static_cast<uint8_t>(i), out, sizeof out) ==
                        packet_len
                    ? 0u
                    : 1u;
    clobber(out);
  });

  char out_line[pete::msg::kMaxDownlinkLine];
  const double downlink_encode = median_ns([&](uint32_t i) {
    clobber(&command);
    failures += pete::msg::encode_downlink(command, static_cast<uint8_t>(i), out_line,
                                           sizeof out_line) == line_len
                    ? 0u
                    : 1u;
    clobber(out_line);
  });

  if (failures != 0 || dec.errors.total() != 0) {
    std::fprintf(stderr, "pete_codec_bench: %u operations failed, %u decoder errors\n", failures,
                 dec.errors.total());
    return 1;
  }
  std::printf(
      "{\"command_downlink_decode_ns\": %.2f, \"state_packet_decode_ns\": %.2f, "
      "\"state_packet_encode_ns\": %.2f, \"command_downlink_encode_ns\": %.2f}\n",
      downlink_decode, packet_decode, packet_encode, downlink_encode);
  return 0;
}
