// brain_host: the Brain firmware's core on fake hardware, as a process. Its serial link (a pty, or
// stdin/stdout) carries exactly the bytes a real V5 Brain puts on its USB user port, and its
// hardware is played through a text side channel. brain/README.md ("brain_host") is the manual.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>

#include "fd_serial.hpp"
#include "pete/core/config.hpp"
#include "side_channel.hpp"
#include "sim_rig.hpp"

namespace {

using pete::host::FdSerial;
using pete::host::Mode;

constexpr const char* kUsage =
    "usage: brain_host [--link pty|stdio] [--lockstep | --realtime] [--side stdio|fds:R,W|none]\n"
    "                  [--phase disabled|autonomous|driver] [--alliance red|blue|unknown]\n"
    "                  [--boot-id HEX] [--jetson-in-autonomous 0|1] [--jetson-in-driver 0|1]\n"
    "                  [--duration-ms MS] [--track-width-m M]\n"
    "\n"
    "The Brain core on fake hardware. --link pty (default) opens a pseudo-terminal and\n"
    "reports its path in the 'ready' line; --link stdio uses stdin (downlink) and stdout\n"
    "(uplink). The side channel (default: stdin/stdout with --link pty, none with --link\n"
    "stdio) takes one command per line ('help' lists them). --lockstep: the side channel's\n"
    "advance/until run the loop on simulated time; --realtime (default): the loop runs every\n"
    "period on the wall clock. --track-width-m: the drive's track instead of the configuration\n"
    "header's (a simulator's robot of another size). brain/README.md documents it all.\n";

struct Options {
  bool pty = true;
  Mode mode = Mode::realtime;
  bool mode_given = false;
  enum class Side { stdio, fds, none } side = Side::stdio;
  bool side_given = false;
  int side_in = 0;
  int side_out = 1;
  std::optional<pete::msg::MatchPhase> phase;
  // The V5 screen pick brain_host starts with (red, as the simulator's robot 0 plays).
  pete::msg::Alliance alliance = pete::msg::Alliance::red;
  std::optional<uint32_t> boot_id;
  bool jetson_in_auto = pete::core::kRobotConfig.jetson_drives_in_autonomous;
  bool jetson_in_driver = pete::core::kRobotConfig.jetson_drives_in_driver;
  uint64_t duration_ms = 0;
  std::optional<float> track_width_m;  // the drive's track instead of kRobotConfig's
};

[[noreturn]] void usage_error(const std::string& what) {
  std::fprintf(stderr, "brain_host: %s\n\n%s", what.c_str(), kUsage);
  std::exit(2);
}

bool parse_bool(const std::string& s, bool& out) {
  if (s == "1" || s == "true") {
    out = true;
    return true;
  }
  if (s == "0" || s == "false") {
    out = false;
    return true;
  }
  return false;
}

Options parse_args(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (a == "--link") {
      const std::string v = value();
      if (v != "pty" && v != "stdio") usage_error("--link must be pty or stdio, not '" + v + "'");
      o.pty = v == "pty";
    } else if (a == "--lockstep" || a == "--realtime") {
      o.mode = a == "--lockstep" ? Mode::lockstep : Mode::realtime;
      o.mode_given = true;
    } else if (a == "--side") {
      const std::string v = value();
      o.side_given = true;
      if (v == "stdio") {
        o.side = Options::Side::stdio;
      } else if (v == "none") {
        o.side = Options::Side::none;
      } else if (v.rfind("fds:", 0) == 0 &&
                 std::sscanf(v.c_str() + 4, "%d,%d", &o.side_in, &o.side_out) == 2 &&
                 o.side_in >= 0 && o.side_out >= 0 &&
                 fcntl(o.side_in, F_GETFD) != -1 && fcntl(o.side_out, F_GETFD) != -1) {
        o.side = Options::Side::fds;
      } else {
        usage_error("--side must be stdio, none or fds:R,W with two open descriptors, not '" + v +
                    "'");
      }
    } else if (a == "--phase") {
      const std::string v = value();
      if (v == "disabled") {
        o.phase = pete::msg::MatchPhase::disabled;
      } else if (v == "autonomous") {
        o.phase = pete::msg::MatchPhase::autonomous;
      } else if (v == "driver") {
        o.phase = pete::msg::MatchPhase::driver;
      } else {
        usage_error("--phase must be disabled, autonomous or driver, not '" + v + "'");
      }
    } else if (a == "--alliance") {
      const std::string v = value();
      if (v == "red") {
        o.alliance = pete::msg::Alliance::red;
      } else if (v == "blue") {
        o.alliance = pete::msg::Alliance::blue;
      } else if (v == "unknown") {
        o.alliance = pete::msg::Alliance::unknown;
      } else {
        usage_error("--alliance must be red, blue or unknown, not '" + v + "'");
      }
    } else if (a == "--boot-id") {
      const std::string v = value();
      char* end = nullptr;
      const unsigned long id = std::strtoul(v.c_str(), &end, 16);
      if (v.empty() || *end != '\0' || id > 0xFFFFFFFFul) usage_error("--boot-id must be hex u32");
      o.boot_id = static_cast<uint32_t>(id);
    } else if (a == "--jetson-in-autonomous" || a == "--jetson-in-driver") {
      const std::string v = value();
      bool& target = a == "--jetson-in-driver" ? o.jetson_in_driver : o.jetson_in_auto;
      if (!parse_bool(v, target)) usage_error(a + " must be 0 or 1");
    } else if (a == "--duration-ms") {
      const std::string v = value();
      char* end = nullptr;
      o.duration_ms = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0') usage_error("--duration-ms must be a whole number");
    } else if (a == "--track-width-m") {
      const std::string v = value();
      char* end = nullptr;
      const float m = std::strtof(v.c_str(), &end);
      if (v.empty() || *end != '\0') usage_error("--track-width-m must be a number of metres");
      pete::core::Config c = pete::core::kRobotConfig;
      c.drive.track_width_m = m;
      if (const char* why = pete::core::config_error(c)) {
        usage_error(std::string("--track-width-m ") + v + ": " + why);
      }
      o.track_width_m = m;
    } else {
      usage_error("unknown option '" + a + "'");
    }
  }
  if (!o.side_given && !o.pty) o.side = Options::Side::none;
  if (o.side == Options::Side::stdio && !o.pty) {
    usage_error("--link stdio uses stdin/stdout for the serial link; give the side channel "
                "--side fds:R,W or --side none");
  }
  if (o.mode == Mode::lockstep && o.side == Options::Side::none) {
    usage_error("--lockstep needs a side channel to drive the clock");
  }
  return o;
}

uint32_t random_boot_id() {
  uint32_t id = 0;
  const int fd = ::open("/dev/urandom", O_RDONLY | O_CLOEXEC);
  if (fd >= 0) {
    if (::read(fd, &id, sizeof id) != static_cast<ssize_t>(sizeof id)) id = 0;
    ::close(fd);
  }
  if (id == 0) {
    id = static_cast<uint32_t>(std::chrono::steady_clock::now().time_since_epoch().count());
  }
  return id;
}

bool write_all(int fd, const std::string& s) {
  std::size_t off = 0;
  while (off < s.size()) {
    const ssize_t w = ::write(fd, s.data() + off, s.size() - off);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    off += static_cast<std::size_t>(w);
  }
  return true;
}

struct Pty {
  int master = -1;
  int slave = -1;  // kept open so the master never reads EIO while no client is attached
  std::string path;
};

Pty open_pty() {
  Pty p;
  p.master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (p.master < 0 || ::grantpt(p.master) != 0 || ::unlockpt(p.master) != 0) {
    std::perror("brain_host: cannot open a pty");
    std::exit(1);
  }
  const char* name = ::ptsname(p.master);
  if (name == nullptr) {
    std::perror("brain_host: ptsname");
    std::exit(1);
  }
  p.path = name;
  p.slave = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  termios tio{};
  if (p.slave < 0 || ::tcgetattr(p.slave, &tio) != 0) {
    std::perror("brain_host: cannot open the pty's slave side");
    std::exit(1);
  }
  // Raw: the wire carries binary frames (0x0a, 0x0d, 0x03 ...) that a line discipline would mangle.
  ::cfmakeraw(&tio);
  ::tcsetattr(p.slave, TCSANOW, &tio);
  ::fcntl(p.master, F_SETFL, ::fcntl(p.master, F_GETFL) | O_NONBLOCK);
  return p;
}

class FdLinkIo final : public pete::host::LinkIo {
 public:
  explicit FdLinkIo(FdSerial& serial) : serial_(serial) {}
  bool wait_rx(uint64_t total, int timeout_ms) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    serial_.pump_rx(0);
    while (serial_.rx_total() < total) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            deadline - std::chrono::steady_clock::now())
                            .count();
      if (left <= 0 || !serial_.rx_open()) return false;
      serial_.pump_rx(static_cast<int>(left));
    }
    return true;
  }
  uint64_t rx_total() const override { return serial_.rx_total(); }
  uint64_t tx_total() const override { return serial_.tx_total(); }

 private:
  FdSerial& serial_;
};

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse_args(argc, argv);
  ::signal(SIGPIPE, SIG_IGN);

  pete::core::Config config = pete::core::kRobotConfig;
  config.jetson_drives_in_autonomous = opt.jetson_in_auto;
  config.jetson_drives_in_driver = opt.jetson_in_driver;
  if (opt.track_width_m) config.drive.track_width_m = *opt.track_width_m;
  const uint32_t boot_id = opt.boot_id ? *opt.boot_id : random_boot_id();

  Pty pty;
  int link_rx = 0, link_tx = 1;
  if (opt.pty) {
    pty = open_pty();
    link_rx = link_tx = pty.master;
  }
  FdSerial serial(link_rx, link_tx);
  pete::host::SimRig rig(config, serial, boot_id);
  // --alliance is the driver's pick on the V5 screen (unknown: none, found from the GPS).
  rig.screen.pick = opt.alliance;
  if (opt.phase) rig.competition.set_phase(*opt.phase);
  FdLinkIo io(serial);
  pete::host::SideChannel side(rig, opt.mode, io);

  const bool has_side = opt.side != Options::Side::none;
  const int side_in = opt.side == Options::Side::fds ? opt.side_in : 0;
  const int side_out = opt.side == Options::Side::fds ? opt.side_out : 1;

  char ready[256];
  std::snprintf(ready, sizeof ready,
                "ready link=%s%s%s mode=%s period_ms=%u boot_id=%08X fingerprint=%08X\n",
                opt.pty ? "pty" : "stdio", opt.pty ? " pty=" : "", opt.pty ? pty.path.c_str() : "",
                opt.mode == Mode::lockstep ? "lockstep" : "realtime", config.loop_period_ms,
                boot_id, pete::msg::kFingerprint);
  if (has_side) {
    write_all(side_out, ready);
  } else {
    std::fputs(ready, stderr);
    std::fflush(stderr);
  }

  const auto start = std::chrono::steady_clock::now();
  auto wall_ms = [&]() -> uint64_t {
    return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                     std::chrono::steady_clock::now() - start)
                                     .count());
  };

  std::string pending;
  bool side_open = has_side;
  bool skipping = false;
  constexpr std::size_t kMaxLine = 4096;
  while (!side.quit()) {
    if (opt.mode == Mode::realtime) {
      const uint64_t now = wall_ms();
      if (opt.duration_ms != 0 && now >= opt.duration_ms) break;
      rig.step_if_due(now);
    } else if (!side_open) {
      break;
    }

    pollfd fds[2];
    nfds_t nfds = 0;
    const bool watch_link = serial.rx_open();
    if (watch_link) fds[nfds++] = {serial.rx_fd(), POLLIN, 0};
    const nfds_t side_slot = nfds;
    if (side_open) fds[nfds++] = {side_in, POLLIN, 0};
    int timeout = -1;
    if (opt.mode == Mode::realtime) {
      const uint64_t now = wall_ms();
      const uint64_t next = rig.next_step_ms();
      timeout = next > now ? static_cast<int>(next - now) : 0;
    }
    if (serial.tx_pending()) {
      serial.flush();
      if (serial.tx_pending() && (timeout < 0 || timeout > 5)) timeout = 5;
    }
    if (nfds == 0 && timeout < 0) break;
    const int r = ::poll(fds, nfds, timeout);
    if (r < 0 && errno != EINTR) break;
    if (r <= 0) continue;
    if (watch_link && (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) != 0) serial.pump_rx(0);
    if (side_open && (fds[side_slot].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
      char buf[4096];
      const ssize_t n = ::read(side_in, buf, sizeof buf);
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        side_open = false;  // the simulator went away
        if (opt.mode == Mode::lockstep) break;
        continue;
      }
      std::size_t from = 0;
      if (skipping) {
        // The rest of an overlong line: drop it up to its newline.
        const auto* nl =
            static_cast<const char*>(std::memchr(buf, '\n', static_cast<std::size_t>(n)));
        if (nl == nullptr) continue;
        skipping = false;
        from = static_cast<std::size_t>(nl - buf) + 1;
      }
      pending.append(buf + from, static_cast<std::size_t>(n) - from);
      std::size_t nl;
      while ((nl = pending.find('\n')) != std::string::npos) {
        std::string line = pending.substr(0, nl);
        pending.erase(0, nl + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string reply = side.handle(line) + "\n";
        if (!write_all(side_out, reply)) side_open = false;
        if (side.quit()) break;
      }
      if (pending.size() > kMaxLine) {
        pending.clear();
        skipping = true;
        if (!write_all(side_out, "error line longer than 4096 bytes\n")) side_open = false;
      }
    }
  }
  serial.flush();
  return 0;
}
