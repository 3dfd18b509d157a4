#include "pete/core/byte_ring.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <thread>
#include <vector>

namespace pete::core {
namespace {

TEST(ByteRing, PassesBytesThroughInOrderAcrossTheWrap) {
  ByteRing<8> ring;
  uint8_t out[8];
  uint8_t next = 0, expect = 0;
  for (int round = 0; round < 50; ++round) {
    uint8_t in[5];
    for (auto& b : in) b = next++;
    ASSERT_EQ(ring.push(in, 5), 5u);
    const std::size_t n = ring.pop(out, sizeof out);
    ASSERT_EQ(n, 5u);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(out[i], expect++);
  }
  EXPECT_EQ(ring.size(), 0u);
  EXPECT_EQ(ring.dropped(), 0u);
}

TEST(ByteRing, DropsAndCountsWhatDoesNotFit) {
  ByteRing<8> ring;
  const uint8_t in[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  EXPECT_EQ(ring.push(in, 12), 8u);
  EXPECT_EQ(ring.dropped(), 4u);
  EXPECT_EQ(ring.size(), 8u);
  uint8_t out[3];
  EXPECT_EQ(ring.pop(out, 3), 3u);
  EXPECT_EQ(out[0], 1);
  EXPECT_EQ(out[2], 3);
  EXPECT_EQ(ring.push(in, 12), 3u);
  EXPECT_EQ(ring.dropped(), 13u);
}

TEST(ByteRing, OneProducerAndOneConsumerThreadLoseNothing) {
  static ByteRing<256> ring;  // static: 256 bytes plus atomics, like the Brain's
  constexpr uint32_t kTotal = 200000;
  std::vector<uint8_t> got;
  got.reserve(kTotal);
  std::thread producer([] {
    uint32_t sent = 0;
    while (sent < kTotal) {
      uint8_t b[7];
      const uint32_t n = std::min<uint32_t>(7, kTotal - sent);
      for (uint32_t i = 0; i < n; ++i) b[i] = static_cast<uint8_t>((sent + i) * 31u);
      // Only offer what fits, so nothing is dropped and the order can be checked.
      if (ByteRing<256>::capacity() - ring.size() < n) {
        std::this_thread::yield();
        continue;
      }
      sent += static_cast<uint32_t>(ring.push(b, n));
    }
  });
  uint8_t buf[64];
  while (got.size() < kTotal) {
    const std::size_t n = ring.pop(buf, sizeof buf);
    got.insert(got.end(), buf, buf + n);
    if (n == 0) std::this_thread::yield();
  }
  producer.join();
  ASSERT_EQ(ring.dropped(), 0u);
  for (uint32_t i = 0; i < kTotal; ++i) ASSERT_EQ(got[i], static_cast<uint8_t>(i * 31u)) << i;
}

}  // namespace
}  // namespace pete::core
