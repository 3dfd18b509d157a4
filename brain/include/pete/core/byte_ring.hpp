// A single-producer single-consumer byte queue between two tasks, without locks or heap: on the
// Brain a reader task blocks in read() on stdin and pushes here, and the control loop pops without
// ever blocking. When full, new bytes are dropped and counted (a Command line cut that way fails
// its CRC and is discarded; the watchdog covers the gap).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace pete::core {

template <std::size_t N>
class ByteRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "capacity must be a power of two");

 public:
  /// Producer side. Returns how many of `n` bytes fit; the rest are dropped and counted.
  std::size_t push(const uint8_t* data, std::size_t n) {
    const uint32_t head = head_.load(std::memory_order_relaxed);
    const uint32_t tail = tail_.load(std::memory_order_acquire);
    const std::size_t space = N - static_cast<std::size_t>(head - tail);
    const std::size_t take = n < space ? n : space;
    for (std::size_t i = 0; i < take; ++i) buf_[(head + i) & (N - 1)] = data[i];
    head_.store(head + static_cast<uint32_t>(take), std::memory_order_release);
    if (take < n) dropped_.fetch_add(static_cast<uint32_t>(n - take), std::memory_order_relaxed);
    return take;
  }

  /// Consumer side. Copies up to `cap` bytes out; returns how many.
  std::size_t pop(uint8_t* out, std::size_t cap) {
    const uint32_t tail = tail_.load(std::memory_order_relaxed);
    const uint32_t head = head_.load(std::memory_order_acquire);
    const std::size_t avail = static_cast<std::size_t>(head - tail);
    const std::size_t take = cap < avail ? cap : avail;
    for (std::size_t i = 0; i < take; ++i) out[i] = buf_[(tail + i) & (N - 1)];
    tail_.store(tail + static_cast<uint32_t>(take), std::memory_order_release);
    return take;
  }

  std::size_t size() const {
    return static_cast<std::size_t>(head_.load(std::memory_order_acquire) -
                                    tail_.load(std::memory_order_acquire));
  }
  static constexpr std::size_t capacity() { return N; }
  uint32_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  uint8_t buf_[N] = {};
  // Free-running indices: their difference is the fill level, even across wrap-around.
  std::atomic<uint32_t> head_{0};
  std::atomic<uint32_t> tail_{0};
  std::atomic<uint32_t> dropped_{0};
};

}  // namespace pete::core
