// The partner link over VEXlink: the relay alone on a fake radio, COBS framing, and the whole
// robot carrying reports Jetson -> radio -> Jetson.
#include "pete/core/partner.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "support.hpp"

namespace pete::core {
namespace {

using test::downlink;
using test::only;
using test::radio_frame;
using test::Rig;

constexpr PartnerConfig kPartner = kRobotConfig.partner;

msg::Partner report(int16_t x_mm, uint8_t rings = 3) {
  msg::Partner p;
  p.x_mm = x_mm;
  p.y_mm = -250;
  p.heading_cdeg = 9000;
  p.flags = msg::PartnerFlags::pose_ok | msg::PartnerFlags::driving;
  p.goal = 255;
  p.rings = rings;
  p.target = msg::TargetKind::ring;
  p.target_id = 255;
  p.target_x_mm = 600;
  p.target_y_mm = -1200;
  p.match_ms = 4000;
  return p;
}

void deliver(host::FakeRadio& radio, const std::vector<uint8_t>& bytes) {
  radio.rx.insert(radio.rx.end(), bytes.begin(), bytes.end());
}

/// Decode every frame the radio was given.
std::vector<msg::Partner> frames_sent(const host::FakeRadio& radio) {
  std::vector<msg::Partner> out;
  wire::CobsAssembler frames;
  wire::ErrorCounters errors;
  for (uint8_t b : radio.sent) {
    if (!frames.feed(b, errors)) continue;
    msg::AnyMessage m;
    wire::Error err{};
    EXPECT_TRUE(msg::decode_packet(frames.packet(), frames.size(), m, err));
    EXPECT_EQ(m.id, msg::Partner::kId);
    out.push_back(m.partner);
  }
  EXPECT_EQ(errors.total(), 0u);
  return out;
}

host::FakeRadio linked_radio() {
  host::FakeRadio r;
  r.is_fitted = true;
  r.linked = true;
  return r;
}

TEST(CobsFrame, RoundTripsEveryByteValueAndResyncsAfterGarbage) {
  std::vector<uint8_t> packet(200);
  for (std::size_t i = 0; i < packet.size(); ++i) packet[i] = static_cast<uint8_t>(i * 7);
  // A valid packet: header, body, CRC.
  uint8_t raw[wire::kMaxPacket];
  std::memcpy(raw + wire::kHeaderSize, packet.data(), packet.size());
  const std::size_t n = wire::seal_packet(raw, 4, 9, packet.size());
  uint8_t frame[wire::kMaxPacket + 4];
  const std::size_t k = wire::cobs_frame(raw, n, frame, sizeof frame);
  ASSERT_GT(k, n);
  EXPECT_EQ(frame[k - 1], 0);
  for (std::size_t i = 0; i + 1 < k; ++i) EXPECT_NE(frame[i], 0) << "a zero inside the frame";

  wire::CobsAssembler a;
  wire::ErrorCounters errors;
  const uint8_t junk[] = {0x05, 0x11, 0x00, 0x02, 0x00};  // two broken frames
  for (uint8_t b : junk) EXPECT_FALSE(a.feed(b, errors));
  EXPECT_GE(errors.total(), 1u);
  bool got = false;
  for (std::size_t i = 0; i < k; ++i) got = a.feed(frame[i], errors);
  ASSERT_TRUE(got);
  ASSERT_EQ(a.size(), n);
  EXPECT_EQ(std::memcmp(a.packet(), raw, n), 0);
}

TEST(CobsFrame, AnOverlongRunIsDroppedOnceAndTheNextFrameDecodes) {
  wire::CobsAssembler a;
  wire::ErrorCounters errors;
  for (int i = 0; i < 2000; ++i) EXPECT_FALSE(a.feed(0x41, errors));
  EXPECT_FALSE(a.feed(0x00, errors));
  EXPECT_EQ(errors[wire::Error::oversize], 1u);
  const auto good = radio_frame(report(100));
  bool got = false;
  for (uint8_t b : good) got = a.feed(b, errors);
  EXPECT_TRUE(got);
}

TEST(PartnerRelay, WithoutARadioTheLinkIsAbsentAndNothingIsSent) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio;  // not fitted
  relay.report(report(100), 0);
  msg::Partner theirs;
  EXPECT_FALSE(relay.step(radio, 0, theirs));
  EXPECT_EQ(relay.link(), msg::PartnerLink::absent);
  EXPECT_TRUE(radio.sent.empty());
}

TEST(PartnerRelay, SendsOnlyTheNewestReportAtMostOncePerPeriod) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  msg::Partner theirs;
  for (uint32_t t = 0; t < 1000; t += 10) {
    relay.report(report(static_cast<int16_t>(t)), t);  // the Jetson reports every 10 ms
    relay.step(radio, t, theirs);
  }
  const auto sent = frames_sent(radio);
  ASSERT_EQ(sent.size(), 1000u / kPartner.period_ms);
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(sent[i].x_mm, static_cast<int16_t>(i * kPartner.period_ms)) << "not the newest";
  }
  // VEXlink's slower direction carries about 520 bytes/s: the reports stay under half of it.
  EXPECT_LE(radio.sent.size(), 520u / 2 + 10u);
  EXPECT_EQ(relay.status(1000).sent, sent.size());
}

TEST(PartnerRelay, AStaleReportIsNotSentAndABusyRadioSendsItLater) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  msg::Partner theirs;
  relay.report(report(1), 0);
  radio.room = 0;  // the transmit queue is full
  relay.step(radio, 0, theirs);
  EXPECT_TRUE(radio.sent.empty());
  EXPECT_EQ(relay.status(0).busy, 1u);
  radio.room = 512;
  relay.step(radio, 10, theirs);
  EXPECT_EQ(frames_sent(radio).size(), 1u);
  // The Jetson goes quiet: its last report ages past report_max_age_ms and is never sent.
  relay.report(report(2), 20);
  radio.sent.clear();
  relay.step(radio, 20 + kPartner.report_max_age_ms + 1, theirs);
  EXPECT_TRUE(radio.sent.empty());
}

TEST(PartnerRelay, TheLinkComesUpWithAReportAndIsLostWhenTheyStop) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  msg::Partner theirs;
  relay.step(radio, 0, theirs);
  EXPECT_EQ(relay.link(), msg::PartnerLink::connecting);
  deliver(radio, radio_frame(report(-700, 5), 0));
  ASSERT_TRUE(relay.step(radio, 10, theirs));
  EXPECT_EQ(theirs.x_mm, -700);
  EXPECT_EQ(theirs.rings, 5);
  EXPECT_EQ(relay.link(), msg::PartnerLink::up);
  EXPECT_EQ(relay.status(60).age_ms, 50);
  relay.step(radio, 10 + kPartner.timeout_ms - 10, theirs);
  EXPECT_EQ(relay.link(), msg::PartnerLink::up);
  relay.step(radio, 10 + kPartner.timeout_ms, theirs);
  EXPECT_EQ(relay.link(), msg::PartnerLink::lost);
  deliver(radio, radio_frame(report(-650), 1));
  relay.step(radio, 2000, theirs);
  EXPECT_EQ(relay.link(), msg::PartnerLink::up);
  // The radio itself losing the partner is lost at once.
  radio.linked = false;
  relay.step(radio, 2010, theirs);
  EXPECT_EQ(relay.link(), msg::PartnerLink::lost);
}

TEST(PartnerRelay, CorruptFramesAndOtherMessagesAreCountedNotDelivered) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  msg::Partner theirs;
  auto frame = radio_frame(report(10), 0);
  frame[4] ^= 0x5A;  // a flipped byte: the CRC fails
  deliver(radio, frame);
  // A Hello where only Partners belong.
  uint8_t packet[msg::kMaxPacket];
  uint8_t hello_frame[msg::kMaxPacket + 4];
  const std::size_t n = msg::encode_packet(test::jetson_hello(), 0, packet, sizeof packet);
  const std::size_t k = wire::cobs_frame(packet, n, hello_frame, sizeof hello_frame);
  radio.rx.insert(radio.rx.end(), hello_frame, hello_frame + k);
  const uint8_t noise[] = {0x13, 0x37, 0x00};
  radio.rx.insert(radio.rx.end(), noise, noise + sizeof noise);
  EXPECT_FALSE(relay.step(radio, 0, theirs));
  EXPECT_EQ(relay.link(), msg::PartnerLink::connecting);
  EXPECT_GE(relay.status(0).errors, 3u);
  EXPECT_EQ(relay.status(0).received, 0u);
  // Then a good one, with a gap in its sequence numbers.
  deliver(radio, radio_frame(report(20), 4));
  deliver(radio, radio_frame(report(30), 7));
  EXPECT_TRUE(relay.step(radio, 10, theirs));
  EXPECT_EQ(theirs.x_mm, 30) << "the newest of the step";
  EXPECT_EQ(relay.status(10).received, 2u);
  EXPECT_EQ(relay.status(10).lost, 2u);
}

TEST(PartnerRelay, AFloodIsReadAFewHundredBytesAStep) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  for (int i = 0; i < 100; ++i) deliver(radio, radio_frame(report(static_cast<int16_t>(i)), 0));
  const std::size_t before = radio.rx.size();
  msg::Partner theirs;
  relay.step(radio, 0, theirs);
  EXPECT_EQ(before - radio.rx.size(), PartnerRelay::kMaxRxPerStep);
}

TEST(PartnerRelay, StatusGoesOutPeriodicallyAndAtOnceOnAChange) {
  PartnerRelay relay(kPartner);
  host::FakeRadio radio = linked_radio();
  msg::Partner theirs;
  relay.step(radio, 0, theirs);
  EXPECT_TRUE(relay.changed());
  EXPECT_TRUE(relay.status_due(0));
  EXPECT_FALSE(relay.changed());
  relay.step(radio, 10, theirs);
  EXPECT_FALSE(relay.status_due(10));
  deliver(radio, radio_frame(report(1), 0));
  relay.step(radio, 20, theirs);
  EXPECT_TRUE(relay.changed());
  EXPECT_TRUE(relay.status_due(20)) << "the link came up";
  EXPECT_FALSE(relay.status_due(30));
  EXPECT_TRUE(relay.status_due(20 + kPartner.status_period_ms));
}

// --- the whole robot -----------------------------------------------------------------------------

TEST(RobotPartner, CarriesTheJetsonsReportOutAndThePartnersIn) {
  Rig r;
  r.sim.radio.is_fitted = true;
  r.sim.radio.linked = true;
  r.handshake();
  r.serial.take_messages();
  r.send(downlink(report(1234, 7), 1));
  r.run(kRobotConfig.loop_period_ms * 2);
  const auto out = frames_sent(r.sim.radio);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].x_mm, 1234);
  EXPECT_EQ(out[0].rings, 7);

  test::Rig& rig = r;
  deliver(rig.sim.radio, radio_frame(report(-900, 2), 0));
  rig.run(kRobotConfig.loop_period_ms * 2);
  const auto msgs = rig.serial.take_messages();
  const auto theirs = only<msg::Partner>(msgs);
  ASSERT_EQ(theirs.size(), 1u);
  EXPECT_EQ(theirs[0].x_mm, -900);
  const auto status = only<msg::PartnerStatus>(msgs);
  ASSERT_FALSE(status.empty());
  EXPECT_EQ(status.back().link, msg::PartnerLink::up);
  EXPECT_EQ(rig.status().partner, msg::PartnerLink::up);

  // The partner goes silent: the Jetson hears it, and a Log says the robot plays alone.
  rig.run(kRobotConfig.partner.timeout_ms + 20);
  const auto later = rig.serial.take_messages();
  const auto st = only<msg::PartnerStatus>(later);
  ASSERT_FALSE(st.empty());
  EXPECT_EQ(st.back().link, msg::PartnerLink::lost);
  bool said = false;
  for (const auto& log : only<msg::Log>(later)) {
    said = said || std::strstr(log.text, "playing alone") != nullptr;
  }
  EXPECT_TRUE(said);
}

TEST(RobotPartner, ReportsBeforeTheHandshakeAreIgnored) {
  Rig r;
  r.sim.radio.is_fitted = true;
  r.sim.radio.linked = true;
  r.send(downlink(report(55), 1));
  r.run(kRobotConfig.loop_period_ms * 3);
  EXPECT_TRUE(r.sim.radio.sent.empty());
  EXPECT_TRUE(only<msg::Partner>(r.serial.take_messages()).empty());
}

}  // namespace
}  // namespace pete::core
