// The pete wire format in C++17: packets, CRC-16, the Jetson->Brain hex-line framing, and the PROS
// serial-stream framing that the Brain's output goes through. Header-only, no heap, no exceptions, no
// RTTI, no PROS headers. protocol/README.md describes every byte; messages.hpp adds the messages.
//
// Packet:   id u8 | seq u8 | len u8 | body[len] | crc16 u16 LE   (CRC-16/CCITT-FALSE over id..body)
// Uplink:   the Brain write()s one packet to its own PROS stream; PROS puts
//           COBS(stream_id[4] || packet) || 0x00 on the USB wire.
// Downlink: ':' || lowercase hex(packet) || '\n'. PROS's serial daemon swallows any "pR" byte pair
//           on stdin; this alphabet contains neither 'p' (0x70) nor 'R' (0x52).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace pete::wire {

inline constexpr std::size_t kHeaderSize = 3;
inline constexpr std::size_t kCrcSize = 2;
inline constexpr std::size_t kOverhead = kHeaderSize + kCrcSize;
inline constexpr std::size_t kMaxBody = 255;
inline constexpr std::size_t kMaxPacket = kOverhead + kMaxBody;
inline constexpr char kLineStart = ':';
inline constexpr char kLineEnd = '\n';
inline constexpr std::size_t kMaxLine = 1 + 2 * kMaxPacket + 1;
inline constexpr std::size_t kStreamIdSize = 4;
// COBS adds at most one byte per 254 plus the leading code byte; PROS appends the 0x00 delimiter.
inline constexpr std::size_t kMaxStreamFrame =
    kStreamIdSize + kMaxPacket + (kStreamIdSize + kMaxPacket) / 254 + 2;

// Why a frame was dropped. The same kinds, with the same names, are counted by the Python decoders.
enum class Error : uint8_t {
  garbage,          // bytes outside any frame, or a character outside the framing's alphabet
  bad_cobs,         // an uplink frame that is not valid COBS
  truncated,        // a frame shorter than its header says, or cut off by the next frame's start
  bad_crc,          // CRC mismatch
  bad_length,       // a length that contradicts the frame or the schema
  unknown_id,       // a message id this schema does not define
  bad_value,        // an enum value, bool or float that no correct peer sends
  wrong_direction,  // a message that is never sent this way
  oversize,         // a frame longer than any valid one
  unknown_stream,   // an uplink frame on a PROS stream we neither decode nor log
};
inline constexpr std::size_t kErrorKinds = 10;

inline constexpr const char* error_name(Error e) {
  constexpr const char* kNames[kErrorKinds] = {
      "garbage",    "bad_cobs",  "truncated",       "bad_crc",  "bad_length",
      "unknown_id", "bad_value", "wrong_direction", "oversize", "unknown_stream",
  };
  return static_cast<std::size_t>(e) < kErrorKinds ? kNames[static_cast<std::size_t>(e)] : "?";
}

struct ErrorCounters {
  uint32_t count[kErrorKinds] = {};
  void add(Error e) { ++count[static_cast<std::size_t>(e)]; }
  uint32_t operator[](Error e) const { return count[static_cast<std::size_t>(e)]; }
  uint32_t total() const {
    uint32_t sum = 0;
    for (uint32_t c : count) sum += c;
    return sum;
  }
};

// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, no final xor. check("123456789") =
// 0x29B1. Bitwise rather than a table: a 40-byte packet costs well under a microsecond on the V5.
inline constexpr uint16_t crc16(const uint8_t* data, std::size_t n, uint16_t crc = 0xFFFF) {
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<uint16_t>(crc ^ (static_cast<uint16_t>(data[i]) << 8));
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 0x8000u) ? static_cast<uint16_t>((crc << 1) ^ 0x1021u)
                            : static_cast<uint16_t>(crc << 1);
    }
  }
  return crc;
}

// Explicit little-endian, whatever the host's byte order.
inline void put_u8(uint8_t* p, uint8_t v) { p[0] = v; }
inline void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
inline void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void put_i8(uint8_t* p, int8_t v) { p[0] = static_cast<uint8_t>(v); }
inline void put_i16(uint8_t* p, int16_t v) { put_u16(p, static_cast<uint16_t>(v)); }
inline void put_i32(uint8_t* p, int32_t v) { put_u32(p, static_cast<uint32_t>(v)); }
inline void put_f32(uint8_t* p, float v) {
  uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  put_u32(p, bits);
}
inline void put_bool(uint8_t* p, bool v) { p[0] = v ? 1 : 0; }

inline uint8_t get_u8(const uint8_t* p) { return p[0]; }
inline uint16_t get_u16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (static_cast<uint16_t>(p[1]) << 8));
}
inline uint32_t get_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
inline int8_t get_i8(const uint8_t* p) { return static_cast<int8_t>(p[0]); }
inline int16_t get_i16(const uint8_t* p) { return static_cast<int16_t>(get_u16(p)); }
inline int32_t get_i32(const uint8_t* p) { return static_cast<int32_t>(get_u32(p)); }
// Floats are checked on their bits, so the test holds even under -ffast-math.
inline bool get_f32(const uint8_t* p, float& out) {
  const uint32_t bits = get_u32(p);
  std::memcpy(&out, &bits, sizeof out);
  return (bits & 0x7F800000u) != 0x7F800000u;
}
inline bool get_bool(const uint8_t* p, bool& out) {
  out = p[0] == 1;
  return p[0] <= 1;
}

// Text fields: copy up to the first NUL and clear the rest, so equal text gives equal bytes.
template <std::size_t N>
inline void set_text(char (&dst)[N], const char* src) {
  std::size_t i = 0;
  for (; src != nullptr && i < N && src[i] != '\0'; ++i) dst[i] = src[i];
  for (; i < N; ++i) dst[i] = '\0';
}
template <std::size_t N>
inline void get_text(const uint8_t* p, char (&dst)[N]) {
  std::size_t i = 0;
  for (; i < N && p[i] != 0; ++i) dst[i] = static_cast<char>(p[i]);
  for (; i < N; ++i) dst[i] = '\0';
}
template <std::size_t N>
inline void put_text(uint8_t* p, const char (&src)[N]) {
  std::size_t i = 0;
  for (; i < N && src[i] != '\0'; ++i) p[i] = static_cast<uint8_t>(src[i]);
  for (; i < N; ++i) p[i] = 0;
}

// Fill in the header and CRC around a body already written at out + kHeaderSize.
inline std::size_t seal_packet(uint8_t* out, uint8_t id, uint8_t seq, std::size_t body_len) {
  out[0] = id;
  out[1] = seq;
  out[2] = static_cast<uint8_t>(body_len);
  put_u16(out + kHeaderSize + body_len, crc16(out, kHeaderSize + body_len));
  return kOverhead + body_len;
}

// Check a packet's length and CRC. On success `body`/`body_len` point into `p`.
inline bool open_packet(const uint8_t* p, std::size_t n, const uint8_t*& body, std::size_t& body_len,
                        Error& err) {
  if (n < kOverhead) {
    err = Error::truncated;
    return false;
  }
  const std::size_t declared = p[2];
  if (n < kOverhead + declared) {
    err = Error::truncated;
    return false;
  }
  if (n > kOverhead + declared) {
    err = Error::bad_length;
    return false;
  }
  if (get_u16(p + kHeaderSize + declared) != crc16(p, kHeaderSize + declared)) {
    err = Error::bad_crc;
    return false;
  }
  body = p + kHeaderSize;
  body_len = declared;
  return true;
}

// ':' hex '\n'. Returns the number of chars written, or 0 if `cap` is too small.
inline std::size_t hex_line(const uint8_t* packet, std::size_t n, char* out, std::size_t cap) {
  constexpr char kHex[] = "0123456789abcdef";
  if (cap < 2 * n + 2) return 0;
  std::size_t k = 0;
  out[k++] = kLineStart;
  for (std::size_t i = 0; i < n; ++i) {
    out[k++] = kHex[packet[i] >> 4];
    out[k++] = kHex[packet[i] & 0x0F];
  }
  out[k++] = kLineEnd;
  return k;
}

// Turns downlink bytes, in any chunking, back into packets whose length and CRC are good. One byte at
// a time so the Brain can feed it straight from read(); bounded buffer, resyncs on ':' or '\n'.
class LineAssembler {
 public:
  // Returns true when a packet is ready in packet()/size(); it stays valid until the next feed().
  bool feed(uint8_t c, ErrorCounters& errors) {
    if (c == static_cast<uint8_t>(kLineStart)) {
      if (state_ == State::in_frame) errors.add(Error::truncated);
      if (state_ == State::garbage) errors.add(Error::garbage);
      start();
      return false;
    }
    if (c == static_cast<uint8_t>(kLineEnd)) {
      const State was = state_;
      state_ = State::idle;
      if (was == State::garbage) errors.add(Error::garbage);
      if (was != State::in_frame) return false;
      if (odd_) {
        errors.add(Error::truncated);
        return false;
      }
      Error err{};
      const uint8_t* body = nullptr;
      std::size_t body_len = 0;
      if (!open_packet(buf_, len_, body, body_len, err)) {
        errors.add(err);
        return false;
      }
      return true;
    }
    switch (state_) {
      case State::idle:
        // Carriage returns and spaces between frames are noise, not errors.
        if (c != '\r' && c != ' ') state_ = State::garbage;
        return false;
      case State::garbage:
      case State::skipping:
        return false;
      case State::in_frame:
        break;
    }
    const int nibble = hex_value(c);
    if (nibble < 0) {
      errors.add(Error::garbage);
      state_ = State::skipping;
      return false;
    }
    if (!odd_) {
      if (len_ == kMaxPacket) {
        errors.add(Error::oversize);
        state_ = State::skipping;
        return false;
      }
      high_ = static_cast<uint8_t>(nibble);
      odd_ = true;
    } else {
      buf_[len_++] = static_cast<uint8_t>((high_ << 4) | nibble);
      odd_ = false;
    }
    return false;
  }
  const uint8_t* packet() const { return buf_; }
  std::size_t size() const { return len_; }

 private:
  enum class State : uint8_t { idle, in_frame, garbage, skipping };
  static int hex_value(uint8_t c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  }
  void start() {
    state_ = State::in_frame;
    len_ = 0;
    odd_ = false;
  }
  uint8_t buf_[kMaxPacket] = {};
  std::size_t len_ = 0;
  uint8_t high_ = 0;
  bool odd_ = false;
  State state_ = State::idle;
};

// Counts packets lost between two received sequence numbers (u8, wrapping).
class SeqTracker {
 public:
  // Returns how many packets went missing before this one.
  uint32_t observe(uint8_t seq) {
    uint32_t lost = 0;
    // A repeated number (gap 255) is not counted: correct senders never repeat.
    if (seen_) lost = static_cast<uint8_t>(seq - last_ - 1);
    if (lost == 0xFF) lost = 0;
    seen_ = true;
    last_ = seq;
    return lost;
  }
  void reset() { seen_ = false; }

 private:
  uint8_t last_ = 0;
  bool seen_ = false;
};

// COBS, as PROS's serial driver applies it to every write() on a stream (brain_host and the tests
// use it to put exactly the real bytes on a host pipe), and as the Brain frames its partner
// reports on VEXlink (cobs_frame, below).
inline std::size_t cobs_encode(const uint8_t* in, std::size_t n, uint8_t* out, std::size_t cap) {
  if (cap < n + n / 254 + 1) return 0;
  std::size_t code_at = 0, k = 1;
  uint8_t code = 1;
  for (std::size_t i = 0; i < n; ++i) {
    if (in[i] == 0) {
      out[code_at] = code;
      code_at = k++;
      code = 1;
      continue;
    }
    out[k++] = in[i];
    // A full block only opens another when more input follows (the usual COBS convention).
    if (++code == 0xFF && i + 1 < n) {
      out[code_at] = code;
      code_at = k++;
      code = 1;
    }
  }
  out[code_at] = code;
  return k;
}

// One PROS stream frame: COBS(stream_id || payload) || 0x00.
inline std::size_t stream_frame(const char (&stream_id)[kStreamIdSize + 1], const uint8_t* payload,
                                std::size_t n, uint8_t* out, std::size_t cap) {
  uint8_t raw[kStreamIdSize + kMaxPacket];
  if (n > kMaxPacket) return 0;
  std::memcpy(raw, stream_id, kStreamIdSize);
  // An empty write may come with a null pointer, which memcpy must not be given even for 0 bytes.
  if (n != 0) std::memcpy(raw + kStreamIdSize, payload, n);
  const std::size_t k = cobs_encode(raw, kStreamIdSize + n, out, cap == 0 ? 0 : cap - 1);
  if (k == 0) return 0;
  out[k] = 0;
  return k + 1;
}

// One COBS frame per packet, ended by 0x00: how a packet crosses a byte link with no framing of
// its own (VEXlink's raw calls). The frame is n + n / 254 + 2 bytes.
inline std::size_t cobs_frame(const uint8_t* packet, std::size_t n, uint8_t* out, std::size_t cap) {
  const std::size_t k = cobs_encode(packet, n, out, cap == 0 ? 0 : cap - 1);
  if (k == 0) return 0;
  out[k] = 0;
  return k + 1;
}

// Turns bytes in any chunking back into the packets cobs_frame framed, whose length and CRC are
// good. Bounded buffer; a bad frame is counted and the next 0x00 starts afresh.
class CobsAssembler {
 public:
  // Returns true when a packet is ready in packet()/size(); it stays valid until the next feed().
  bool feed(uint8_t c, ErrorCounters& errors) {
    if (c != 0) {
      if (len_ == sizeof buf_) {
        if (!overflow_) errors.add(Error::oversize);
        overflow_ = true;
        return false;
      }
      buf_[len_++] = c;
      return false;
    }
    const std::size_t n = len_;
    const bool overflow = overflow_;
    len_ = 0;
    overflow_ = false;
    if (overflow || n == 0) return false;
    // Decode in place: the output never runs ahead of the input.
    std::size_t in = 0, out = 0;
    while (in < n) {
      const uint8_t code = buf_[in++];
      if (in + code - 1 > n) {
        errors.add(Error::bad_cobs);
        return false;
      }
      for (uint8_t i = 1; i < code; ++i) buf_[out++] = buf_[in++];
      if (code != 0xFF && in < n) buf_[out++] = 0;
    }
    Error err{};
    const uint8_t* body = nullptr;
    std::size_t body_len = 0;
    if (!open_packet(buf_, out, body, body_len, err)) {
      errors.add(err);
      return false;
    }
    size_ = out;
    return true;
  }
  const uint8_t* packet() const { return buf_; }
  std::size_t size() const { return size_; }

 private:
  uint8_t buf_[kMaxPacket + kMaxPacket / 254 + 1] = {};
  std::size_t len_ = 0;
  std::size_t size_ = 0;
  bool overflow_ = false;
};

}  // namespace pete::wire
