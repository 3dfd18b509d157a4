// The Brain's USB serial link on a host file descriptor pair (a pty master, or stdin/stdout),
// carrying exactly the bytes a real Brain would: each packet one PROS `pete` stream frame, each
// text write one `sout` frame; the downlink raw, into a bounded buffer like PROS's 4 KB one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "pete/core/hal.hpp"

namespace pete::host {

class FdSerial final : public core::SerialLink {
 public:
  static constexpr std::size_t kRxCapacity = 4096;   // PROS's stdin ring buffer
  static constexpr std::size_t kTxCapacity = 65536;  // beyond this, whole frames are dropped

  FdSerial(int rx_fd, int tx_fd) : rx_fd_(rx_fd), tx_fd_(tx_fd) {}

  std::size_t read(uint8_t* buf, std::size_t cap) override;
  bool write_packet(const uint8_t* data, std::size_t n) override;
  void write_text(const char* text, std::size_t n) override;

  /// Move whatever the fd has ready into the rx buffer, waiting at most timeout_ms for the first
  /// byte (0 = do not wait). Returns false once the fd reached end of file or failed.
  bool pump_rx(int timeout_ms);
  /// Write out pending uplink bytes as far as the fd takes them now.
  void flush();

  uint64_t rx_total() const { return rx_total_; }   // bytes read from the fd
  uint64_t tx_total() const { return tx_total_; }   // bytes handed to the fd
  uint64_t rx_dropped() const { return rx_dropped_; }
  uint64_t tx_dropped() const { return tx_dropped_; }
  bool rx_open() const { return rx_open_; }
  int rx_fd() const { return rx_fd_; }
  int tx_fd() const { return tx_fd_; }
  bool tx_pending() const { return !tx_.empty(); }

 private:
  void queue_frame(const char (&stream)[5], const uint8_t* data, std::size_t n);

  int rx_fd_;
  int tx_fd_;
  std::deque<uint8_t> rx_;
  std::vector<uint8_t> tx_;
  uint64_t rx_total_ = 0;
  uint64_t tx_total_ = 0;
  uint64_t rx_dropped_ = 0;
  uint64_t tx_dropped_ = 0;
  bool rx_open_ = true;
};

}  // namespace pete::host
