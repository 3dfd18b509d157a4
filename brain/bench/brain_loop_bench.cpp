// Host CPU time of one Brain control-loop step (Robot::step with everything it does: competition
// status, downlink decode, watchdog, arbitration, drive limits, GPS checks, State/Log encoding and
// the PROS stream framing a write() costs). Prints one JSON object; bench/brain_loop.py reports it.
//
// Built -O2 without sanitizers. Each step is timed with the thread's CPU clock, so time the OS gave
// to other processes does not count; the worst case still includes cache misses and interrupts.
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "fakes.hpp"
#include "pete/core/config.hpp"
#include "pete/core/robot.hpp"
#include "pete/messages.hpp"

namespace {

using namespace pete;

/// A serial link with no allocation, so the timing is the core's and PROS-like framing only.
class BenchSerial final : public core::SerialLink {
 public:
  std::size_t read(uint8_t* buf, std::size_t cap) override {
    const std::size_t n = std::min(cap, rx_len - rx_pos);
    std::memcpy(buf, rx + rx_pos, n);
    rx_pos += n;
    return n;
  }
  bool write_packet(const uint8_t* data, std::size_t n) override {
    // PROS COBS-encodes inside write(): part of the step's cost on the Brain.
    frame_len = wire::stream_frame(msg::kStream, data, n, frame, sizeof frame);
    ++packets;
    return frame_len != 0;
  }
  void write_text(const char* text, std::size_t n) override {
    frame_len = wire::stream_frame("sout", reinterpret_cast<const uint8_t*>(text), n, frame,
                                   sizeof frame);
  }
  void load(const uint8_t* data, std::size_t n) {
    std::memcpy(rx, data, n);
    rx_len = n;
    rx_pos = 0;
  }

  uint8_t rx[4096] = {};
  std::size_t rx_len = 0;
  std::size_t rx_pos = 0;
  uint8_t frame[wire::kMaxStreamFrame] = {};
  std::size_t frame_len = 0;
  uint64_t packets = 0;
};

uint64_t thread_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<uint64_t>(ts.tv_nsec);
}

struct Stats {
  double p50_us, p99_us, max_us, mean_us;
  std::size_t steps;
};

Stats summarise(std::vector<uint64_t>& ns) {
  std::sort(ns.begin(), ns.end());
  double sum = 0;
  for (uint64_t v : ns) sum += static_cast<double>(v);
  auto at = [&](double q) {
    const auto rank = static_cast<std::size_t>(q * static_cast<double>(ns.size()));
    const std::size_t i = std::min(ns.size() - 1, rank);
    return static_cast<double>(ns[i]) / 1000.0;
  };
  return {at(0.50), at(0.99), static_cast<double>(ns.back()) / 1000.0,
          sum / static_cast<double>(ns.size()) / 1000.0, ns.size()};
}

std::size_t command_line(uint32_t seq, char* out, std::size_t cap) {
  msg::Command c;
  c.seq = seq;
  c.linear = 0.4f + 0.001f * static_cast<float>(seq % 100);
  c.angular = -1.5f;
  c.intake = (seq & 1) != 0;
  c.valid_ms = 250;
  return msg::encode_downlink(c, static_cast<uint8_t>(seq), out, cap);
}

struct Rig {
  host::FakeClock clock;
  host::FakeGps gps;
  host::FakeImu imu;
  host::FakeDrivetrain drive;
  host::FakeIntake intake;
  host::FakeGoalClamp clamp;
  host::FakeLift lift;
  host::FakeCompetition competition;
  host::FakeDriverInput driver;
  host::FakeScreen screen;
  host::FakeRadio radio;
  BenchSerial serial;
  core::Robot robot;
  uint64_t t_ms = 0;

  Rig()
      : robot(core::kRobotConfig,
              core::Hardware{clock, gps, imu, drive, intake, clamp, lift, serial, competition, driver, screen, radio},
              0xB0B0CAFE) {
    drive.calls.reserve(host::FakeDrivetrain::kKeep);
    competition.set_phase(msg::MatchPhase::autonomous);
    gps.set_pose(0.5, -0.7, 91.0, 0.02);
    // Handshake first, so every timed step does the full connected work.
    msg::Hello h;
    h.fingerprint = msg::kFingerprint;
    h.protocol_version = msg::kProtocolVersion;
    h.role = msg::Role::jetson;
    h.boot_id = 7;
    char line[msg::kMaxDownlinkLine];
    const std::size_t n = msg::encode_downlink(h, 0, line, sizeof line);
    serial.load(reinterpret_cast<const uint8_t*>(line), n);
    step();
  }
  void step() {
    clock.set_ms(t_ms);
    robot.step();
    t_ms += core::kRobotConfig.loop_period_ms;
  }
};

// nominal: one Command per step, State every other step, a phase change (Log + slew reset) and a
// GPS dropout now and then. flood: every step's downlink is the most the step will decode (1 KiB),
// mostly garbage with Commands inside, which is the worst input the loop can be handed.
Stats run(bool flood, std::size_t steps) {
  Rig rig;
  std::vector<uint64_t> ns;
  ns.reserve(steps);
  char line[msg::kMaxDownlinkLine];
  uint8_t rx[core::Link::kMaxRxPerStep];
  for (std::size_t i = 0; i < steps; ++i) {
    const uint32_t seq = static_cast<uint32_t>(i + 1);
    std::size_t n = command_line(seq, line, sizeof line);
    if (flood) {
      std::size_t k = 0;
      while (k + n + 7 < sizeof rx) {
        std::memcpy(rx + k, "zz:0q1\n", 7);  // garbage, then a frame cut by a bad digit
        k += 7;
        std::memcpy(rx + k, line, n);
        k += n;
      }
      rig.serial.load(rx, k);
    } else {
      rig.serial.load(reinterpret_cast<const uint8_t*>(line), n);
    }
    if (i % 500 == 250) rig.competition.set_phase(msg::MatchPhase::driver);
    if (i % 500 == 0) rig.competition.set_phase(msg::MatchPhase::autonomous);
    if (i % 1000 == 600) rig.gps.set_status(msg::GpsStatus::error);
    if (i % 1000 == 700) rig.gps.set_pose(0.5, -0.7, 91.0, 0.02);
    rig.drive.calls.clear();
    const uint64_t t0 = thread_ns();
    rig.step();
    ns.push_back(thread_ns() - t0);
  }
  if (rig.robot.link().counters().commands == 0 || rig.serial.packets == 0) {
    std::fprintf(stderr, "brain_loop_bench: the rig never connected; the numbers would mean "
                         "nothing\n");
    std::exit(1);
  }
  return summarise(ns);
}

void print(const char* name, const Stats& s, bool last) {
  std::printf(
      "  \"%s\": {\"steps\": %zu, \"p50_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.3f, "
      "\"mean_us\": %.3f}%s\n",
      name, s.steps, s.p50_us, s.p99_us, s.max_us, s.mean_us, last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t steps = 20000;
  if (argc == 2) steps = static_cast<std::size_t>(std::strtoul(argv[1], nullptr, 10));
  if (steps < 100) {
    std::fprintf(stderr, "usage: brain_loop_bench [STEPS >= 100]\n");
    return 2;
  }
  run(false, 2000);  // warm caches and the branch predictors
  run(true, 2000);
  const Stats nominal = run(false, steps);
  const Stats flood = run(true, steps);
  std::printf("{\n  \"loop_period_ms\": %u,\n", core::kRobotConfig.loop_period_ms);
  print("nominal", nominal, false);
  print("flood", flood, true);
  std::printf("}\n");
  return 0;
}
