// GoogleTest suite for the generated C++ codec (brain/include/pete/messages.hpp and wire.hpp): the
// golden vectors that the Python codec is held to as well, and everything a noisy USB line can do to
// the Brain's downlink decoder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "pete/messages.hpp"
#include "pete/wire.hpp"

namespace {

using pete::msg::AnyMessage;
using pete::msg::Command;
using pete::msg::DownlinkDecoder;
using pete::msg::Hello;
using pete::msg::Log;
using pete::msg::Partner;
using pete::msg::PartnerStatus;
using pete::msg::State;
using pete::wire::Error;

struct GoldenVector {
  const char* name;
  AnyMessage msg;
  const char* packet_hex;
  const char* uplink_hex;
  const char* downlink;
};

const GoldenVector kGolden[] = {
#include "golden_vectors.inc"
};

void PrintTo(const GoldenVector& v, std::ostream* os) { *os << v.name << " " << v.packet_hex; }

// --- helpers ------------------------------------------------------------------------------------

std::vector<uint8_t> from_hex(std::string_view hex) {
  auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  };
  std::vector<uint8_t> out;
  EXPECT_EQ(hex.size() % 2, 0u) << hex;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    const int hi = nibble(hex[i]);
    const int lo = nibble(hex[i + 1]);
    EXPECT_TRUE(hi >= 0 && lo >= 0) << hex;
    out.push_back(static_cast<uint8_t>((hi << 4) | lo));
  }
  return out;
}

std::string to_hex(const uint8_t* p, std::size_t n) {
  constexpr char kHex[] = "0123456789abcdef";
  std::string s;
  for (std::size_t i = 0; i < n; ++i) {
    s += kHex[p[i] >> 4];
    s += kHex[p[i] & 0x0F];
  }
  return s;
}

std::string to_hex(const std::vector<uint8_t>& v) { return to_hex(v.data(), v.size()); }

// The generated operator== per message, applied to whichever one the id names.
bool same(const AnyMessage& a, const AnyMessage& b) {
  if (a.id != b.id || a.seq != b.seq) return false;
  switch (a.id) {
    case Hello::kId:
      return a.hello == b.hello;
    case State::kId:
      return a.state == b.state;
    case Command::kId:
      return a.command == b.command;
    case Log::kId:
      return a.log == b.log;
    case Partner::kId:
      return a.partner == b.partner;
    case PartnerStatus::kId:
      return a.partnerstatus == b.partnerstatus;
  }
  return false;
}

std::vector<uint8_t> packet_of(const AnyMessage& m) {
  uint8_t buf[pete::msg::kMaxPacket];
  const std::size_t n = pete::msg::encode_packet(m, buf, sizeof buf);
  EXPECT_GT(n, 0u);
  return {buf, buf + n};
}

// Through the typed encode_downlink, which is what the Jetson-side C++ tools call.
std::string downlink_of(const AnyMessage& m) {
  char buf[pete::msg::kMaxDownlinkLine];
  std::size_t n = 0;
  switch (m.id) {
    case Hello::kId:
      n = pete::msg::encode_downlink(m.hello, m.seq, buf, sizeof buf);
      break;
    case State::kId:
      n = pete::msg::encode_downlink(m.state, m.seq, buf, sizeof buf);
      break;
    case Command::kId:
      n = pete::msg::encode_downlink(m.command, m.seq, buf, sizeof buf);
      break;
    case Log::kId:
      n = pete::msg::encode_downlink(m.log, m.seq, buf, sizeof buf);
      break;
    case Partner::kId:
      n = pete::msg::encode_downlink(m.partner, m.seq, buf, sizeof buf);
      break;
    case PartnerStatus::kId:
      n = pete::msg::encode_downlink(m.partnerstatus, m.seq, buf, sizeof buf);
      break;
  }
  EXPECT_GT(n, 0u);
  return {buf, n};
}

// A downlink line for arbitrary packet bytes, including ones no encoder would produce.
std::string line_of(const std::vector<uint8_t>& packet) {
  std::string line = ":";
  line += to_hex(packet);
  line += '\n';
  return line;
}

// Recompute the CRC after editing a packet, so that the edit itself is what the decoder sees.
void reseal(std::vector<uint8_t>& p) {
  ASSERT_GE(p.size(), pete::wire::kOverhead);
  const std::size_t n = p.size() - pete::wire::kCrcSize;
  pete::wire::put_u16(p.data() + n, pete::wire::crc16(p.data(), n));
}

std::vector<AnyMessage> feed_all(DownlinkDecoder& dec, std::string_view bytes) {
  std::vector<AnyMessage> got;
  AnyMessage out;
  for (char c : bytes) {
    if (dec.feed(static_cast<uint8_t>(c), out)) got.push_back(out);
  }
  return got;
}

bool decodes(const std::vector<uint8_t>& p, AnyMessage& out, Error& err) {
  return pete::msg::decode_packet(p.data(), p.size(), out, err);
}

// Decoding must fail, with exactly this kind.
void expect_rejected(const std::vector<uint8_t>& p, Error want) {
  AnyMessage out;
  Error err{};
  EXPECT_FALSE(decodes(p, out, err)) << to_hex(p);
  EXPECT_STREQ(pete::wire::error_name(err), pete::wire::error_name(want)) << to_hex(p);
}

// The one body byte where two encodings differ: finds a field's offset without restating the layout.
std::size_t differing_byte(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  EXPECT_EQ(a.size(), b.size());
  std::size_t at = 0, count = 0;
  for (std::size_t i = pete::wire::kHeaderSize; i + pete::wire::kCrcSize < a.size(); ++i) {
    if (a[i] != b[i]) {
      at = i;
      ++count;
    }
  }
  EXPECT_EQ(count, 1u);
  return at;
}

std::size_t first_difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    if (a[i] != b[i]) return i;
  }
  ADD_FAILURE() << "no difference";
  return 0;
}

// splitmix64: a seed always reproduces the same sequence.
struct Rng {
  uint64_t s;
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  uint32_t u32() { return static_cast<uint32_t>(next() >> 32); }
  uint32_t below(uint32_t n) { return static_cast<uint32_t>((next() >> 32) % n); }
  float finite_f32() {
    for (;;) {
      const uint32_t bits = u32();
      if ((bits & 0x7F800000u) == 0x7F800000u) continue;
      float f = 0;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
  }
};

AnyMessage random_command(Rng& rng) {
  AnyMessage m;
  m.id = Command::kId;
  m.seq = static_cast<uint8_t>(rng.u32());
  m.command.seq = rng.u32();
  m.command.linear = rng.finite_f32();
  m.command.angular = rng.finite_f32();
  m.command.intake = (rng.u32() & 1u) != 0;
  m.command.valid_ms = static_cast<uint16_t>(rng.u32());
  return m;
}

AnyMessage golden(const char* name, std::size_t nth = 0) {
  for (const GoldenVector& v : kGolden) {
    if (std::strcmp(v.name, name) == 0 && nth-- == 0) return v.msg;
  }
  ADD_FAILURE() << "no golden " << name;
  return {};
}

float float_of(uint32_t bits) {
  float f = 0;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// --- golden vectors -----------------------------------------------------------------------------

class Golden : public testing::TestWithParam<GoldenVector> {};

TEST_P(Golden, EncodePacketGivesTheGoldenBytes) {
  const GoldenVector& v = GetParam();
  EXPECT_EQ(to_hex(packet_of(v.msg)), v.packet_hex);
  // A buffer one byte short is refused rather than overrun.
  uint8_t buf[pete::msg::kMaxPacket];
  const std::size_t need = std::strlen(v.packet_hex) / 2;
  EXPECT_EQ(pete::msg::encode_packet(v.msg, buf, need - 1), 0u);
  EXPECT_EQ(pete::msg::encode_packet(v.msg, buf, need), need);
}

TEST_P(Golden, DecodePacketGivesAnEqualMessage) {
  const GoldenVector& v = GetParam();
  const std::vector<uint8_t> bytes = from_hex(v.packet_hex);
  AnyMessage out;
  Error err{};
  ASSERT_TRUE(decodes(bytes, out, err)) << pete::wire::error_name(err);
  EXPECT_TRUE(same(out, v.msg));
  // Every shorter prefix is truncated; one byte more contradicts the length byte.
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    expect_rejected({bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)},
                    Error::truncated);
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  expect_rejected(longer, Error::bad_length);
}

TEST_P(Golden, StreamFrameGivesTheGoldenUplink) {
  const GoldenVector& v = GetParam();
  const std::vector<uint8_t> packet = from_hex(v.packet_hex);
  uint8_t frame[pete::wire::kMaxStreamFrame];
  const std::size_t n = pete::wire::stream_frame(pete::msg::kStream, packet.data(), packet.size(),
                                                 frame, sizeof frame);
  ASSERT_GT(n, 0u);
  EXPECT_EQ(to_hex(frame, n), v.uplink_hex);
  EXPECT_EQ(pete::wire::stream_frame(pete::msg::kStream, packet.data(), packet.size(), frame, n - 1),
            0u);
}

TEST_P(Golden, EncodeDownlinkGivesTheGoldenLine) {
  const GoldenVector& v = GetParam();
  const std::string line = downlink_of(v.msg);
  EXPECT_EQ(line, v.downlink);
  // PROS's serial daemon eats "pR"; the line's alphabet cannot form it.
  EXPECT_EQ(line.find("pR"), std::string::npos);
  EXPECT_EQ(line.find_first_not_of(":0123456789abcdef\n"), std::string::npos) << line;
}

TEST_P(Golden, DownlinkDecoderDeliversOnlyWhatTheJetsonSends) {
  const GoldenVector& v = GetParam();
  DownlinkDecoder dec;
  const std::vector<AnyMessage> got = feed_all(dec, v.downlink);
  bool known = false;
  const bool jetson_sends = pete::msg::sent_by_jetson(pete::msg::direction_of(v.msg.id, known));
  ASSERT_TRUE(known);
  if (jetson_sends) {
    ASSERT_EQ(got.size(), 1u);
    EXPECT_TRUE(same(got[0], v.msg));
    EXPECT_EQ(dec.received, 1u);
    EXPECT_EQ(dec.errors.total(), 0u);
  } else {
    EXPECT_TRUE(got.empty());
    EXPECT_EQ(dec.received, 0u);
    EXPECT_EQ(dec.errors[Error::wrong_direction], 1u);
    EXPECT_EQ(dec.errors.total(), 1u);
  }
}

INSTANTIATE_TEST_SUITE_P(Vectors, Golden, testing::ValuesIn(kGolden),
                         [](const testing::TestParamInfo<GoldenVector>& param_info) {
                           return std::to_string(param_info.index) + "_" + param_info.param.name;
                         });

TEST(GoldenSet, CoversEveryMessageAndBothDirections) {
  bool seen[7] = {};
  for (const GoldenVector& v : kGolden) {
    ASSERT_GE(v.msg.id, 1);
    ASSERT_LE(v.msg.id, 6);
    seen[v.msg.id] = true;
  }
  EXPECT_TRUE(seen[Hello::kId] && seen[State::kId] && seen[Command::kId] && seen[Log::kId] &&
              seen[Partner::kId] && seen[PartnerStatus::kId]);
}

TEST(Schema, FingerprintConstantMatchesTheHelloGolden) {
  int hellos = 0;
  for (const GoldenVector& v : kGolden) {
    if (v.msg.id != Hello::kId) continue;
    ++hellos;
    EXPECT_EQ(v.msg.hello.fingerprint, pete::msg::kFingerprint);
    EXPECT_EQ(v.msg.hello.protocol_version, pete::msg::kProtocolVersion);
  }
  EXPECT_GT(hellos, 0);
}

// --- wire primitives ----------------------------------------------------------------------------

TEST(Crc16, CcittFalseCheckValue) {
  constexpr uint8_t kCheck[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  static_assert(pete::wire::crc16(kCheck, sizeof kCheck) == 0x29B1);
  EXPECT_EQ(pete::wire::crc16(kCheck, sizeof kCheck), 0x29B1);
  EXPECT_EQ(pete::wire::crc16(kCheck, 0), 0xFFFF);
  // Chained over two pieces gives the same as over the whole.
  EXPECT_EQ(pete::wire::crc16(kCheck + 4, 5, pete::wire::crc16(kCheck, 4)), 0x29B1);
}

TEST(Wire, ErrorNamesMatchThePythonKinds) {
  const char* want[] = {"garbage",    "bad_cobs",  "truncated",       "bad_crc",  "bad_length",
                        "unknown_id", "bad_value", "wrong_direction", "oversize", "unknown_stream"};
  ASSERT_EQ(sizeof want / sizeof want[0], pete::wire::kErrorKinds);
  for (std::size_t i = 0; i < pete::wire::kErrorKinds; ++i) {
    EXPECT_STREQ(pete::wire::error_name(static_cast<Error>(i)), want[i]);
  }
  EXPECT_STREQ(pete::wire::error_name(static_cast<Error>(200)), "?");
}

TEST(Wire, LittleEndianRoundTrip) {
  uint8_t b[4] = {};
  pete::wire::put_u32(b, 0x12345678u);
  EXPECT_EQ(to_hex(b, 4), "78563412");
  EXPECT_EQ(pete::wire::get_u32(b), 0x12345678u);
  pete::wire::put_i16(b, -2);
  EXPECT_EQ(to_hex(b, 2), "feff");
  EXPECT_EQ(pete::wire::get_i16(b), -2);
  pete::wire::put_f32(b, -1.25f);
  EXPECT_EQ(to_hex(b, 4), "0000a0bf");
}

TEST(SeqTracker, CountsGapsAcrossTheWrap) {
  pete::wire::SeqTracker t;
  EXPECT_EQ(t.observe(250), 0u);  // the first one seen has no predecessor
  EXPECT_EQ(t.observe(251), 0u);
  EXPECT_EQ(t.observe(254), 2u);
  EXPECT_EQ(t.observe(1), 2u);  // 255 and 0 went missing
  EXPECT_EQ(t.observe(1), 0u);  // a repeat is not 255 losses: correct senders never repeat
  EXPECT_EQ(t.observe(3), 1u);
  t.reset();
  EXPECT_EQ(t.observe(77), 0u);
}

// A test-local COBS decoder, written from the definition, to check the encoder against.
bool cobs_decode(const uint8_t* in, std::size_t n, std::vector<uint8_t>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < n) {
    const uint8_t code = in[i++];
    if (code == 0) return false;
    for (uint8_t k = 1; k < code; ++k) {
      if (i >= n || in[i] == 0) return false;
      out.push_back(in[i++]);
    }
    if (code != 0xFF && i < n) out.push_back(0);
  }
  return true;
}

TEST(StreamFrame, IsCobsOfStreamIdAndPayloadForEveryLength) {
  Rng rng{7};
  for (std::size_t len = 0; len <= pete::wire::kMaxPacket; ++len) {
    for (int variant = 0; variant < 3; ++variant) {
      std::vector<uint8_t> payload(len);
      for (uint8_t& b : payload) {
        // All zeros, no zeros (the long-block case), or random.
        b = variant == 0 ? 0 : variant == 1 ? static_cast<uint8_t>(1 + rng.below(255))
                                            : static_cast<uint8_t>(rng.u32());
      }
      uint8_t frame[pete::wire::kMaxStreamFrame];
      const std::size_t n = pete::wire::stream_frame(pete::msg::kStream, payload.data(), len,
                                                     frame, sizeof frame);
      ASSERT_GT(n, 0u) << len;
      ASSERT_LE(n, pete::wire::kMaxStreamFrame);
      EXPECT_EQ(frame[n - 1], 0);
      std::vector<uint8_t> raw;
      ASSERT_TRUE(cobs_decode(frame, n - 1, raw)) << len << " " << to_hex(frame, n);
      std::vector<uint8_t> want = {'p', 'e', 't', 'e'};
      want.insert(want.end(), payload.begin(), payload.end());
      ASSERT_EQ(to_hex(raw), to_hex(want)) << "len " << len << " variant " << variant;
      if (variant == 1) {
        // Without zeros, COBS costs one code byte per started 254-byte block, and no more: a
        // block that ends exactly with the input opens no empty one (as PROS and Python's cobs).
        const std::size_t raw_len = want.size();
        EXPECT_EQ(n, raw_len + 1 + (raw_len - 1) / 254 + 1) << len;
      }
    }
  }
  uint8_t frame[pete::wire::kMaxStreamFrame];
  const uint8_t big[pete::wire::kMaxPacket + 1] = {};
  EXPECT_EQ(pete::wire::stream_frame(pete::msg::kStream, big, sizeof big, frame, sizeof frame), 0u);
  EXPECT_EQ(pete::wire::stream_frame(pete::msg::kStream, big, 1, frame, 0), 0u);
}

// --- packet decoding: values no correct peer sends ------------------------------------------------

TEST(DecodePacket, UnknownIdIsRejected) {
  for (uint8_t id : {uint8_t{0}, uint8_t{7}, uint8_t{0x70}, uint8_t{255}}) {
    std::vector<uint8_t> p = packet_of(golden("Command"));
    p[0] = id;
    reseal(p);
    expect_rejected(p, Error::unknown_id);
    DownlinkDecoder dec;
    EXPECT_TRUE(feed_all(dec, line_of(p)).empty());
    EXPECT_EQ(dec.errors[Error::unknown_id], 1u);
  }
}

TEST(DecodePacket, BadLengthIsRejected) {
  // A well-formed packet whose body is the wrong size for its id.
  std::vector<uint8_t> p = packet_of(golden("Command"));
  p.insert(p.end() - 2, 0x00);
  p[2] = static_cast<uint8_t>(p[2] + 1);
  reseal(p);
  expect_rejected(p, Error::bad_length);
  std::vector<uint8_t> shorter = packet_of(golden("Command"));
  shorter.erase(shorter.end() - 3);
  shorter[2] = static_cast<uint8_t>(shorter[2] - 1);
  reseal(shorter);
  expect_rejected(shorter, Error::bad_length);
  // More bytes than the length byte accounts for, or fewer.
  std::vector<uint8_t> extra = packet_of(golden("Command"));
  extra.push_back(0x55);
  expect_rejected(extra, Error::bad_length);
  std::vector<uint8_t> claims_more = packet_of(golden("Command"));
  claims_more[2] = 200;
  expect_rejected(claims_more, Error::truncated);

  DownlinkDecoder dec;
  EXPECT_TRUE(feed_all(dec, line_of(p) + line_of(shorter) + line_of(extra)).empty());
  EXPECT_EQ(dec.errors[Error::bad_length], 3u);
  EXPECT_EQ(dec.errors.total(), 3u);
}

TEST(DecodePacket, CorruptCrcIsRejected) {
  std::vector<uint8_t> p = packet_of(golden("Command"));
  p.back() ^= 0x01;
  expect_rejected(p, Error::bad_crc);
  p = packet_of(golden("State"));
  p[10] ^= 0x80;
  expect_rejected(p, Error::bad_crc);
}

TEST(DecodePacket, NonFiniteFloatsAreBadValues) {
  const uint32_t kBad[] = {0x7F800000u, 0xFF800000u, 0x7FC00000u, 0x7FC00001u, 0xFF800001u,
                           0x7FFFFFFFu};
  float Command::*const command_floats[] = {&Command::linear, &Command::angular};
  float State::*const state_floats[] = {&State::x,         &State::y,          &State::heading,
                                        &State::gps_error, &State::left_speed, &State::right_speed};
  int cases = 0;
  for (uint32_t bits : kBad) {
    const float f = float_of(bits);
    ASSERT_FALSE(std::isfinite(f));
    for (auto field : command_floats) {
      AnyMessage m = golden("Command");
      m.command.*field = f;
      const std::vector<uint8_t> p = packet_of(m);
      expect_rejected(p, Error::bad_value);
      DownlinkDecoder dec;
      EXPECT_TRUE(feed_all(dec, line_of(p)).empty());
      EXPECT_EQ(dec.errors[Error::bad_value], 1u);
      ++cases;
    }
    for (auto field : state_floats) {
      AnyMessage m = golden("State");
      m.state.*field = f;
      expect_rejected(packet_of(m), Error::bad_value);
      ++cases;
    }
  }
  EXPECT_EQ(cases, 6 * 8);
  // The extremes of the finite range are fine.
  AnyMessage m = golden("Command");
  m.command.linear = std::numeric_limits<float>::max();
  m.command.angular = -std::numeric_limits<float>::denorm_min();
  AnyMessage out;
  Error err{};
  ASSERT_TRUE(decodes(packet_of(m), out, err));
  EXPECT_TRUE(same(out, m));
}

// Set one enum or bool byte (found by diffing two valid encodings) to `value` and re-seal.
std::vector<uint8_t> with_byte(const AnyMessage& a, const AnyMessage& b, uint8_t value) {
  std::vector<uint8_t> p = packet_of(a);
  p[differing_byte(p, packet_of(b))] = value;
  reseal(p);
  return p;
}

TEST(DecodePacket, InvalidEnumsAreBadValues) {
  AnyMessage brain = golden("Hello", 0);
  AnyMessage jetson = brain;
  jetson.hello.role = pete::msg::Role::jetson;
  for (uint8_t v : {uint8_t{0}, uint8_t{3}, uint8_t{255}}) {
    const std::vector<uint8_t> p = with_byte(brain, jetson, v);
    expect_rejected(p, Error::bad_value);
    DownlinkDecoder dec;  // Hello is sent both ways, so this one reaches the value check.
    EXPECT_TRUE(feed_all(dec, line_of(p)).empty());
    EXPECT_EQ(dec.errors[Error::bad_value], 1u);
    EXPECT_EQ(dec.errors.total(), 1u);
  }
  // And each valid value is accepted through the same byte.
  for (uint8_t v : {uint8_t{1}, uint8_t{2}}) {
    AnyMessage out;
    Error err{};
    EXPECT_TRUE(decodes(with_byte(brain, jetson, v), out, err));
    EXPECT_EQ(static_cast<uint8_t>(out.hello.role), v);
  }

  const AnyMessage state = golden("State", 0);
  AnyMessage other = state;
  other.state.phase = pete::msg::MatchPhase::driver;
  expect_rejected(with_byte(state, other, 3), Error::bad_value);
  other = state;
  other.state.alliance = pete::msg::Alliance::blue;
  expect_rejected(with_byte(state, other, 3), Error::bad_value);
  other = state;
  other.state.gps_status = pete::msg::GpsStatus::absent;
  expect_rejected(with_byte(state, other, 4), Error::bad_value);
  expect_rejected(with_byte(state, other, 0xFF), Error::bad_value);

  const AnyMessage log = golden("Log", 0);
  other = log;
  other.log.level = pete::msg::LogLevel::debug;
  expect_rejected(with_byte(log, other, 4), Error::bad_value);
}

TEST(DecodePacket, BoolOtherThanZeroOrOneIsABadValue) {
  const AnyMessage on = golden("Command", 0);
  AnyMessage off = on;
  off.command.intake = !on.command.intake;
  for (uint8_t v : {uint8_t{2}, uint8_t{0x80}, uint8_t{0xFF}}) {
    const std::vector<uint8_t> p = with_byte(on, off, v);
    expect_rejected(p, Error::bad_value);
    DownlinkDecoder dec;
    EXPECT_TRUE(feed_all(dec, line_of(p)).empty());
    EXPECT_EQ(dec.errors[Error::bad_value], 1u);
  }
}

TEST(DecodePacket, ARejectedPacketLeavesTheCallersMessageAlone) {
  // The Brain may keep its last good Command in the same AnyMessage it decodes into: a corrupt
  // frame must not half-overwrite it.
  const AnyMessage keep = golden("Command", 0);
  AnyMessage bad = keep;
  bad.seq = static_cast<uint8_t>(keep.seq + 1);
  bad.command.linear = 2.0f;
  bad.command.angular = std::numeric_limits<float>::quiet_NaN();
  AnyMessage out = keep;
  Error err{};
  EXPECT_FALSE(decodes(packet_of(bad), out, err));
  EXPECT_TRUE(same(out, keep));

  DownlinkDecoder dec;
  std::string stream = line_of(packet_of(bad));       // bad_value
  stream += downlink_of(golden("State", 0));           // wrong_direction
  std::vector<uint8_t> crc = packet_of(golden("Command", 1));
  crc[5] ^= 0x10;
  stream += line_of(crc);                              // bad_crc
  for (char c : stream) EXPECT_FALSE(dec.feed(static_cast<uint8_t>(c), out));
  EXPECT_TRUE(same(out, keep));
  EXPECT_EQ(dec.errors.total(), 3u);
}

// --- text fields --------------------------------------------------------------------------------

TEST(Text, SetTextTruncatesAndZeroFills) {
  char field[16];
  std::memset(field, 'x', sizeof field);
  pete::wire::set_text(field, "0123456789abcdefTOO LONG");
  EXPECT_EQ(std::string(field, sizeof field), "0123456789abcdef");  // no terminator needed
  pete::wire::set_text(field, "short");
  EXPECT_EQ(std::string(field, sizeof field), std::string("short") + std::string(11, '\0'));
  pete::wire::set_text(field, nullptr);
  EXPECT_EQ(std::string(field, sizeof field), std::string(16, '\0'));
}

TEST(Text, LongTextIsCutToTheFieldOnTheWire) {
  AnyMessage m;
  m.id = Log::kId;
  m.log.level = pete::msg::LogLevel::warning;
  const std::string text(60, 'q');
  pete::wire::set_text(m.log.text, text.c_str());
  const std::vector<uint8_t> p = packet_of(m);
  ASSERT_EQ(p.size(), pete::wire::kOverhead + Log::kBodySize);
  AnyMessage out;
  Error err{};
  ASSERT_TRUE(decodes(p, out, err));
  EXPECT_EQ(std::string(out.log.text, sizeof out.log.text), text.substr(0, 48));
}

TEST(Text, BytesAfterANulAreDroppedOnDecode) {
  AnyMessage a = golden("Log", 1);  // a field filled to the last byte
  AnyMessage b = a;
  pete::wire::set_text(b.log.text, "");
  std::vector<uint8_t> p = packet_of(a);
  const std::size_t first = first_difference(p, packet_of(b));
  p[first + 2] = 0;  // "ab\0defg..."
  reseal(p);
  AnyMessage out;
  Error err{};
  ASSERT_TRUE(decodes(p, out, err));
  EXPECT_EQ(std::string(out.log.text, sizeof out.log.text),
            std::string(a.log.text, 2) + std::string(46, '\0'));
  // So equal text always gives equal bytes, whatever followed the NUL on the wire.
  AnyMessage c = a;
  pete::wire::set_text(c.log.text, std::string(a.log.text, 2).c_str());
  EXPECT_EQ(to_hex(packet_of(out)), to_hex(packet_of(c)));
}

// --- the downlink decoder on a noisy line -------------------------------------------------------

TEST(Downlink, ResyncsAfterGarbage) {
  const AnyMessage cmd = golden("Command", 0);
  const std::string line = downlink_of(cmd);
  struct Case {
    std::string before;
    Error kind;
    uint32_t count;
  };
  std::string binary("\x00\xff\x70\x52 junk", 9);
  const Case cases[] = {
      {"hello world\n", Error::garbage, 1},  // a stray text line
      {binary, Error::garbage, 1},           // binary junk running into the frame's ':'
      {":zz\n", Error::garbage, 1},          // a frame with characters outside [0-9a-f]
      {":0307ZZ", Error::garbage, 1},        // ... cut off by the next frame
      {":03070FD1\n", Error::garbage, 1},    // upper case is not in the alphabet
      {"::::", Error::truncated, 4},         // empty frames, each cut by the next ':'
  };
  for (const Case& c : cases) {
    DownlinkDecoder dec;
    const std::vector<AnyMessage> got = feed_all(dec, c.before + line);
    ASSERT_EQ(got.size(), 1u) << c.before;
    EXPECT_TRUE(same(got[0], cmd));
    EXPECT_EQ(dec.errors[c.kind], c.count) << c.before;
    EXPECT_EQ(dec.errors.total(), c.count) << c.before;
  }
  // Long runs of random bytes (no ':' or newline), ended by a newline or by the next frame, leave
  // nothing behind.
  Rng rng{11};
  std::string noise;
  while (noise.size() < 5000) {
    const char ch = static_cast<char>(rng.u32());
    if (ch != ':' && ch != '\n') noise += ch;
  }
  DownlinkDecoder dec;
  const std::vector<AnyMessage> got = feed_all(dec, noise + "\n" + line + noise + line);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(same(got[0], cmd));
  EXPECT_TRUE(same(got[1], cmd));
  EXPECT_EQ(dec.errors[Error::garbage], 2u);
  EXPECT_EQ(dec.errors.total(), 2u);
}

TEST(Downlink, TruncatedFramesAreNeverDelivered) {
  const std::string line = downlink_of(golden("Command", 0));
  const AnyMessage next = golden("Command", 1);
  const std::string next_line = downlink_of(next);
  // Cut anywhere before the newline and followed by the next frame.
  for (std::size_t k = 1; k + 1 < line.size(); ++k) {
    DownlinkDecoder dec;
    const std::vector<AnyMessage> got = feed_all(dec, line.substr(0, k) + next_line);
    ASSERT_EQ(got.size(), 1u) << k;
    EXPECT_TRUE(same(got[0], next));
    EXPECT_EQ(dec.errors[Error::truncated], 1u) << k;
    EXPECT_EQ(dec.errors.total(), 1u) << k;
  }
  // A ':' in the middle of a line cuts it in two; neither half is a message.
  for (std::size_t k = 2; k + 1 < line.size(); ++k) {
    DownlinkDecoder dec;
    const std::string cut = line.substr(0, k) + ":" + line.substr(k);
    EXPECT_TRUE(feed_all(dec, cut).empty()) << cut;
    EXPECT_GE(dec.errors[Error::truncated], 1u) << cut;
    EXPECT_EQ(dec.errors.total(), 2u) << cut;
  }
  // An odd number of hex digits.
  DownlinkDecoder dec;
  EXPECT_TRUE(feed_all(dec, line.substr(0, line.size() - 2) + "\n").empty());
  EXPECT_EQ(dec.errors[Error::truncated], 1u);
}

TEST(Downlink, NoSingleBitFlipIsDeliveredAsAnotherMessage) {
  const AnyMessage next = golden("Command", 1);
  const std::string next_line = downlink_of(next);
  int caught_by_crc_or_length = 0;
  for (std::size_t nth = 0; nth < 2; ++nth) {
    const std::string line = downlink_of(golden("Command", nth));
    for (std::size_t i = 0; i < line.size(); ++i) {
      for (int bit = 0; bit < 8; ++bit) {
        std::string flipped = line;
        flipped[i] = static_cast<char>(flipped[i] ^ (1 << bit));
        DownlinkDecoder dec;
        const std::vector<AnyMessage> got = feed_all(dec, flipped + next_line);
        // Only the intact frame after it comes through; the flip is counted, whatever it hit.
        ASSERT_EQ(got.size(), 1u) << "byte " << i << " bit " << bit;
        EXPECT_TRUE(same(got[0], next)) << "byte " << i << " bit " << bit;
        EXPECT_GE(dec.errors.total(), 1u) << "byte " << i << " bit " << bit;
        caught_by_crc_or_length += static_cast<int>(dec.errors[Error::bad_crc] +
                                                    dec.errors[Error::bad_length] +
                                                    dec.errors[Error::truncated]);
      }
    }
  }
  // Some flips turn one hex digit into another: those reach (and are stopped by) the packet checks.
  EXPECT_GT(caught_by_crc_or_length, 50);
}

TEST(Downlink, OversizeLinesAreDroppedAndCounted) {
  const AnyMessage cmd = golden("Command", 0);
  const std::string line = downlink_of(cmd);
  // The longest packet the framing can carry is still decoded (here: an id the schema lacks).
  std::vector<uint8_t> longest(pete::wire::kMaxPacket, 0x11);
  longest[0] = 0x7E;
  longest[2] = static_cast<uint8_t>(pete::wire::kMaxBody);
  reseal(longest);
  {
    DownlinkDecoder dec;
    EXPECT_TRUE(feed_all(dec, line_of(longest) + line).size() == 1u);
    EXPECT_EQ(dec.errors[Error::unknown_id], 1u);
    EXPECT_EQ(dec.errors[Error::oversize], 0u);
  }
  // One byte more is oversize, and so is an endless one; the next frame still decodes.
  for (std::size_t digits : {2 * pete::wire::kMaxPacket + 2, std::size_t{20000}}) {
    DownlinkDecoder dec;
    std::string stream = ":";
    stream.append(digits, 'a');
    stream += '\n';
    stream += line;
    const std::vector<AnyMessage> got = feed_all(dec, stream);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_TRUE(same(got[0], cmd));
    EXPECT_EQ(dec.errors[Error::oversize], 1u);
    EXPECT_EQ(dec.errors.total(), 1u);
  }
  EXPECT_LE(pete::msg::kMaxDownlinkLine, pete::wire::kMaxLine);
}

TEST(Downlink, CarriageReturnsAndBlankLinesBetweenFramesAreNoise) {
  const AnyMessage a = golden("Command", 0);
  const AnyMessage b = golden("Hello", 1);
  DownlinkDecoder dec;
  const std::vector<AnyMessage> got =
      feed_all(dec, "\r\n\r\n" + downlink_of(a) + "\r\n \r\n\n" + downlink_of(b) + "\n\n\r");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(same(got[0], a));
  EXPECT_TRUE(same(got[1], b));
  EXPECT_EQ(dec.errors.total(), 0u);
  // A CR inside a frame is not part of its alphabet: the frame is dropped, not misread.
  std::string crlf = downlink_of(a);
  crlf.insert(crlf.end() - 1, '\r');
  DownlinkDecoder dec2;
  EXPECT_TRUE(feed_all(dec2, crlf).empty());
  EXPECT_EQ(dec2.errors[Error::garbage], 1u);
}

TEST(Downlink, AMessageIsReadyExactlyAtItsNewline) {
  const std::string line = downlink_of(golden("Command", 0));
  DownlinkDecoder dec;
  AnyMessage out;
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 0; i < line.size(); ++i) {
      EXPECT_EQ(dec.feed(static_cast<uint8_t>(line[i]), out), i + 1 == line.size()) << i;
    }
  }
  EXPECT_EQ(dec.received, 3u);
}

TEST(Downlink, LongNoisyStreamInRandomReadChunks) {
  // Many messages, with the reads the Brain's serial task would do cutting them anywhere.
  Rng rng{2024};
  std::vector<AnyMessage> sent;
  std::string wire;
  uint32_t dropped = 0;
  for (uint32_t i = 0; i < 3000; ++i) {
    AnyMessage m = random_command(rng);
    if (i % 7 == 3) {
      m = golden("Hello", 1);
    }
    m.seq = static_cast<uint8_t>(i);  // wraps several times
    if (i % 97 == 50) {
      ++dropped;  // never sent: shows up as a gap in seq
      continue;
    }
    sent.push_back(m);
    wire += downlink_of(m);
    if (rng.below(4) == 0) wire += rng.below(2) ? "\r\n" : "\n";
  }
  DownlinkDecoder dec;
  std::vector<AnyMessage> got;
  AnyMessage out;
  for (std::size_t at = 0; at < wire.size();) {
    const std::size_t chunk = 1 + rng.below(64);
    for (std::size_t k = at; k < at + chunk && k < wire.size(); ++k) {
      if (dec.feed(static_cast<uint8_t>(wire[k]), out)) got.push_back(out);
    }
    at += chunk;
  }
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) ASSERT_TRUE(same(got[i], sent[i])) << i;
  EXPECT_EQ(dec.received, sent.size());
  EXPECT_EQ(dec.lost, dropped);
  EXPECT_EQ(dec.errors.total(), 0u);
}

TEST(Downlink, NoLineEverContainsPThenR) {
  Rng rng{99};
  for (const GoldenVector& v : kGolden) {
    EXPECT_EQ(std::string(v.downlink).find("pR"), std::string::npos);
  }
  for (int i = 0; i < 20000; ++i) {
    AnyMessage m = random_command(rng);
    if (i % 2 == 0) {
      // Bodies full of 0x70 0x52 pairs, the bytes PROS would eat if they reached the wire raw.
      uint32_t bits = 0x52705270u;
      std::memcpy(&m.command.linear, &bits, sizeof bits);
      m.command.seq = 0x52705270u;
      m.seq = 0x70;
    }
    const std::string line = downlink_of(m);
    ASSERT_EQ(line.find("pR"), std::string::npos) << line;
    ASSERT_EQ(line.find_first_not_of(":0123456789abcdef\n"), std::string::npos) << line;
  }
}

}  // namespace
