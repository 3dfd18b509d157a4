// pete_codec_tool: the C++ codec behind a pipe, so tests/protocol/test_cross_language.py can hold it
// to the Python codec byte for byte.
//
//   pete_codec_tool roundtrip      packet hex lines in; each decoded and re-encoded, or `error <kind>`
//   pete_codec_tool random N SEED  N random valid packets (hex lines), every message type
//   pete_codec_tool downlink       raw downlink bytes in; `msg <packet hex>` per message delivered, then
//                                  `errors <kind>=<n> ...` and `received <n> lost <n>`
//   pete_codec_tool uplink         packet hex lines in; the raw PROS stream frames out (binary)
//
// A malformed input line (not hex) is reported on stderr with exit status 2.
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "pete/messages.hpp"
#include "pete/wire.hpp"

namespace {

using pete::msg::AnyMessage;

constexpr int kUsageError = 2;

int usage() {
  std::fputs(
      "usage: pete_codec_tool roundtrip | random N SEED | downlink | uplink\n"
      "  roundtrip      read packet hex lines, print each re-encoded packet or 'error <kind>'\n"
      "  random N SEED  print N random valid packets as hex, one per line\n"
      "  downlink       read raw downlink bytes, print 'msg <hex>' per message and the counters\n"
      "  uplink         read packet hex lines, write their PROS stream frames (binary)\n",
      stderr);
  return kUsageError;
}

std::string to_hex(const uint8_t* p, std::size_t n) {
  constexpr char kHex[] = "0123456789abcdef";
  std::string s;
  s.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    s += kHex[p[i] >> 4];
    s += kHex[p[i] & 0x0F];
  }
  return s;
}

int hex_nibble(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// One line of stdin without its newline (and without a CR before it). False at end of input.
bool read_line(std::string& line) {
  line.clear();
  int c = 0;
  bool any = false;
  while ((c = std::getchar()) != EOF) {
    any = true;
    if (c == '\n') break;
    line += static_cast<char>(c);
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return any;
}

// Hex text to bytes; on a bad character or an odd length, says so on stderr and returns false.
bool parse_hex(const std::string& line, std::size_t line_no, std::vector<uint8_t>& out) {
  out.clear();
  if (line.size() % 2 != 0) {
    std::fprintf(stderr, "pete_codec_tool: line %zu: odd number of hex digits (%zu)\n", line_no,
                 line.size());
    return false;
  }
  for (std::size_t i = 0; i < line.size(); i += 2) {
    const int hi = hex_nibble(line[i]);
    const int lo = hex_nibble(line[i + 1]);
    if (hi < 0 || lo < 0) {
      const std::size_t at = hi < 0 ? i : i + 1;
      std::fprintf(stderr, "pete_codec_tool: line %zu: character %zu (0x%02x) is not a hex digit\n",
                   line_no, at + 1, static_cast<unsigned>(static_cast<unsigned char>(line[at])));
      return false;
    }
    out.push_back(static_cast<uint8_t>((hi << 4) | lo));
  }
  return true;
}

int roundtrip() {
  std::string line;
  std::vector<uint8_t> packet;
  for (std::size_t line_no = 1; read_line(line); ++line_no) {
    if (!parse_hex(line, line_no, packet)) return kUsageError;
    AnyMessage m;
    pete::wire::Error err{};
    if (!pete::msg::decode_packet(packet.data(), packet.size(), m, err)) {
      std::printf("error %s\n", pete::wire::error_name(err));
      continue;
    }
    uint8_t out[pete::msg::kMaxPacket];
    const std::size_t n = pete::msg::encode_packet(m, out, sizeof out);
    std::printf("%s\n", to_hex(out, n).c_str());
  }
  return 0;
}

// splitmix64: tiny, and the same seed gives the same packets on every platform.
struct Rng {
  uint64_t s;
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  uint32_t u32() { return static_cast<uint32_t>(next() >> 32); }
  uint16_t u16() { return static_cast<uint16_t>(next() >> 48); }
  uint8_t u8() { return static_cast<uint8_t>(next() >> 56); }
  uint32_t below(uint32_t n) { return static_cast<uint32_t>((next() >> 32) % n); }
  bool coin() { return (next() >> 63) != 0; }

  // Any finite f32, weighted towards the values a codec gets wrong: signed zeros, subnormals, the
  // largest and smallest normals, and everyday robot-sized numbers.
  float f32() {
    static constexpr uint32_t kEdges[] = {
        0x00000000u, 0x80000000u,  // +0, -0
        0x00000001u, 0x80000001u,  // smallest subnormals
        0x007FFFFFu, 0x00800000u,  // largest subnormal, smallest normal
        0x7F7FFFFFu, 0xFF7FFFFFu,  // +-FLT_MAX
        0x3F800000u, 0xBF800000u,  // +-1
    };
    uint32_t bits = 0;
    switch (below(4)) {
      case 0:
        bits = kEdges[below(sizeof kEdges / sizeof kEdges[0])];
        break;
      case 1: {
        // Uniform in about +-4: positions, speeds, turn rates.
        const float f = (static_cast<float>(u16()) / 8192.0f - 4.0f) * (coin() ? 1.0f : -1.0f);
        std::memcpy(&bits, &f, sizeof bits);
        break;
      }
      default:
        do {
          bits = u32();
        } while ((bits & 0x7F800000u) == 0x7F800000u);
    }
    float f = 0;
    std::memcpy(&f, &bits, sizeof f);
    return f;
  }

  // ASCII 0x01..0x7F (valid UTF-8 for the Python side), any length up to and including N.
  template <std::size_t N>
  void text(char (&dst)[N]) {
    char buf[N + 1] = {};
    const std::size_t len = below(static_cast<uint32_t>(N + 1));
    for (std::size_t i = 0; i < len; ++i) buf[i] = static_cast<char>(1 + below(127));
    pete::wire::set_text(dst, buf);
  }
};

AnyMessage random_message(Rng& rng, uint8_t id) {
  AnyMessage m;
  m.id = id;
  m.seq = rng.u8();
  switch (id) {
    case pete::msg::Hello::kId:
      m.hello.fingerprint = rng.coin() ? pete::msg::kFingerprint : rng.u32();
      m.hello.protocol_version = rng.u16();
      m.hello.role = rng.coin() ? pete::msg::Role::brain : pete::msg::Role::jetson;
      m.hello.boot_id = rng.u32();
      rng.text(m.hello.software_version);
      break;
    case pete::msg::State::kId:
      m.state.seq = rng.u32();
      m.state.time_ms = rng.u32();
      m.state.phase = static_cast<pete::msg::MatchPhase>(rng.below(3));
      m.state.phase_ms = rng.u32();
      m.state.alliance = static_cast<pete::msg::Alliance>(rng.below(3));
      m.state.x = rng.f32();
      m.state.y = rng.f32();
      m.state.heading = rng.f32();
      m.state.gps_error = rng.f32();
      m.state.gps_status = static_cast<pete::msg::GpsStatus>(rng.below(4));
      m.state.left_speed = rng.f32();
      m.state.right_speed = rng.f32();
      m.state.last_command_seq = rng.u32();
      m.state.faults = static_cast<pete::msg::Fault>(rng.below(1u << 6));  // the defined bits
      break;
    case pete::msg::Command::kId:
      m.command.seq = rng.u32();
      m.command.linear = rng.f32();
      m.command.angular = rng.f32();
      m.command.intake = rng.coin();
      m.command.valid_ms = rng.u16();
      break;
    case pete::msg::Log::kId:
      m.log.level = static_cast<pete::msg::LogLevel>(rng.below(4));
      m.log.time_ms = rng.u32();
      rng.text(m.log.text);
      break;
  }
  return m;
}

bool parse_u64(const char* s, uint64_t& out) {
  if (s == nullptr || *s == '\0' || *s == '-') return false;
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(s, &end, 0);
  if (errno != 0 || *end != '\0') return false;
  out = v;
  return true;
}

int random_packets(const char* count_arg, const char* seed_arg) {
  uint64_t count = 0, seed = 0;
  if (!parse_u64(count_arg, count) || !parse_u64(seed_arg, seed)) {
    std::fprintf(stderr, "pete_codec_tool: random needs N and SEED as unsigned integers\n");
    return kUsageError;
  }
  static constexpr uint8_t kIds[] = {pete::msg::Hello::kId, pete::msg::State::kId,
                                     pete::msg::Command::kId, pete::msg::Log::kId};
  constexpr uint32_t kTypes = sizeof kIds / sizeof kIds[0];
  Rng rng{seed};
  for (uint64_t i = 0; i < count; ++i) {
    // The first lap takes each type in turn, so even a small N covers them all.
    const uint8_t id = i < kTypes ? kIds[i] : kIds[rng.below(kTypes)];
    const AnyMessage m = random_message(rng, id);
    uint8_t out[pete::msg::kMaxPacket];
    const std::size_t n = pete::msg::encode_packet(m, out, sizeof out);
    std::printf("%s\n", to_hex(out, n).c_str());
  }
  return 0;
}

int downlink() {
  pete::msg::DownlinkDecoder dec;
  AnyMessage m;
  uint8_t buf[4096];
  std::size_t got = 0;
  while ((got = std::fread(buf, 1, sizeof buf, stdin)) > 0) {
    for (std::size_t i = 0; i < got; ++i) {
      if (!dec.feed(buf[i], m)) continue;
      uint8_t out[pete::msg::kMaxPacket];
      const std::size_t n = pete::msg::encode_packet(m, out, sizeof out);
      std::printf("msg %s\n", to_hex(out, n).c_str());
    }
  }
  std::printf("errors");
  for (std::size_t k = 0; k < pete::wire::kErrorKinds; ++k) {
    const auto kind = static_cast<pete::wire::Error>(k);
    if (dec.errors[kind] != 0) std::printf(" %s=%u", pete::wire::error_name(kind), dec.errors[kind]);
  }
  std::printf("\nreceived %u lost %u\n", dec.received, dec.lost);
  return 0;
}

int uplink() {
  std::string line;
  std::vector<uint8_t> packet;
  for (std::size_t line_no = 1; read_line(line); ++line_no) {
    if (!parse_hex(line, line_no, packet)) return kUsageError;
    uint8_t frame[pete::wire::kMaxStreamFrame];
    const std::size_t n = pete::wire::stream_frame(pete::msg::kStream, packet.data(), packet.size(),
                                                   frame, sizeof frame);
    if (n == 0) {
      std::fprintf(stderr, "pete_codec_tool: line %zu: %zu bytes is longer than any packet (%zu)\n",
                   line_no, packet.size(), pete::wire::kMaxPacket);
      return kUsageError;
    }
    std::fwrite(frame, 1, n, stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const std::string mode = argv[1];
  int rc = kUsageError;
  if (mode == "roundtrip" && argc == 2) {
    rc = roundtrip();
  } else if (mode == "random" && argc == 4) {
    rc = random_packets(argv[2], argv[3]);
  } else if (mode == "downlink" && argc == 2) {
    rc = downlink();
  } else if (mode == "uplink" && argc == 2) {
    rc = uplink();
  } else {
    return usage();
  }
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "pete_codec_tool: could not write output\n");
    return 1;
  }
  return rc;
}
