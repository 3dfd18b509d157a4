// A fixed-capacity text builder for Log messages. newlib's printf family may allocate (its float
// and reentrancy paths do), and the core allocates nothing after start-up, so it formats by hand.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pete::core {

template <std::size_t N>
class Text {
 public:
  Text& add(const char* s) {
    for (; s != nullptr && *s != '\0'; ++s) put(*s);
    return *this;
  }
  Text& add_u32(uint32_t v) {
    char digits[10];
    std::size_t n = 0;
    do {
      digits[n++] = static_cast<char>('0' + v % 10);
      v /= 10;
    } while (v != 0);
    while (n > 0) put(digits[--n]);
    return *this;
  }
  Text& add_hex32(uint32_t v) {
    constexpr char kHex[] = "0123456789ABCDEF";
    for (int shift = 28; shift >= 0; shift -= 4) put(kHex[(v >> shift) & 0xF]);
    return *this;
  }
  const char* c_str() const { return buf_; }
  std::size_t size() const { return len_; }
  /// True when something did not fit (the text is cut, never overrun).
  bool truncated() const { return truncated_; }

 private:
  void put(char c) {
    if (len_ + 1 < N) {
      buf_[len_++] = c;
      buf_[len_] = '\0';
    } else {
      truncated_ = true;
    }
  }
  char buf_[N] = {};
  std::size_t len_ = 0;
  bool truncated_ = false;
};

}  // namespace pete::core
