#include "fakes.hpp"

#include <algorithm>

namespace pete::host {

std::vector<uint8_t> pros_frame(const char (&stream)[5], const uint8_t* data, std::size_t n) {
  std::vector<uint8_t> out(wire::kMaxStreamFrame);
  const std::size_t k = wire::stream_frame(stream, data, n, out.data(), out.size());
  out.resize(k);
  return out;
}

std::size_t MemorySerial::read(uint8_t* buf, std::size_t cap) {
  const std::size_t n = std::min(cap, rx.size());
  std::copy_n(rx.begin(), n, buf);
  rx.erase(rx.begin(), rx.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

bool MemorySerial::write_packet(const uint8_t* data, std::size_t n) {
  if (refuse_writes) return false;
  const std::vector<uint8_t> frame = pros_frame(msg::kStream, data, n);
  wire.insert(wire.end(), frame.begin(), frame.end());
  packets.emplace_back(data, data + n);
  return true;
}

void MemorySerial::write_text(const char* text_, std::size_t n) {
  const auto* bytes = reinterpret_cast<const uint8_t*>(text_);
  const std::vector<uint8_t> frame = pros_frame("sout", bytes, n);
  wire.insert(wire.end(), frame.begin(), frame.end());
  text.append(text_, n);
}

std::vector<msg::AnyMessage> MemorySerial::take_messages() {
  std::vector<msg::AnyMessage> out;
  for (const auto& p : packets) {
    msg::AnyMessage m;
    wire::Error err{};
    if (msg::decode_packet(p.data(), p.size(), m, err)) out.push_back(m);
  }
  packets.clear();
  return out;
}

}  // namespace pete::host
