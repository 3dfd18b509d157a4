#include "fd_serial.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "fakes.hpp"
#include "pete/messages.hpp"

namespace pete::host {

std::size_t FdSerial::read(uint8_t* buf, std::size_t cap) {
  const std::size_t n = std::min(cap, rx_.size());
  std::copy_n(rx_.begin(), n, buf);
  rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

bool FdSerial::write_packet(const uint8_t* data, std::size_t n) {
  const std::size_t before = tx_dropped_;
  queue_frame(msg::kStream, data, n);
  flush();
  return tx_dropped_ == before;
}

void FdSerial::write_text(const char* text, std::size_t n) {
  // PROS frames each write() separately; long text is written in pieces a frame can carry.
  const auto* bytes = reinterpret_cast<const uint8_t*>(text);
  while (n > 0) {
    const std::size_t piece = std::min(n, wire::kMaxPacket);
    queue_frame("sout", bytes, piece);
    bytes += piece;
    n -= piece;
  }
  flush();
}

void FdSerial::queue_frame(const char (&stream)[5], const uint8_t* data, std::size_t n) {
  const std::vector<uint8_t> frame = pros_frame(stream, data, n);
  if (tx_.size() + frame.size() > kTxCapacity) {
    ++tx_dropped_;  // nobody is reading: drop whole frames, never half of one
    return;
  }
  tx_.insert(tx_.end(), frame.begin(), frame.end());
}

void FdSerial::flush() {
  while (!tx_.empty()) {
    const ssize_t w = ::write(tx_fd_, tx_.data(), tx_.size());
    if (w > 0) {
      tx_total_ += static_cast<uint64_t>(w);
      tx_.erase(tx_.begin(), tx_.begin() + w);
      continue;
    }
    if (w < 0 && errno == EINTR) continue;
    if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      // The reader went away (EPIPE, EIO): a real Brain's output just goes nowhere.
      tx_dropped_ += 1;
      tx_.clear();
    }
    return;
  }
}

bool FdSerial::pump_rx(int timeout_ms) {
  if (!rx_open_) return false;
  pollfd p{rx_fd_, POLLIN, 0};
  int wait = timeout_ms;
  for (;;) {
    const int r = ::poll(&p, 1, wait);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return true;
    if ((p.revents & (POLLIN | POLLHUP | POLLERR)) == 0) return true;
    uint8_t buf[4096];
    const ssize_t n = ::read(rx_fd_, buf, sizeof buf);
    if (n < 0 && (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    if (n < 0 && errno == EIO) {
      // A pty master reads EIO while no client has the slave open: nothing arrived.
      return true;
    }
    if (n <= 0) {
      rx_open_ = false;
      return false;
    }
    rx_total_ += static_cast<uint64_t>(n);
    for (ssize_t i = 0; i < n; ++i) {
      if (rx_.size() < kRxCapacity) {
        rx_.push_back(buf[i]);
      } else {
        ++rx_dropped_;
      }
    }
    if (static_cast<std::size_t>(n) < sizeof buf) return true;
    wait = 0;  // more may be waiting: drain without blocking
  }
}

}  // namespace pete::host
