#include "pete/core/config.hpp"

#include <gtest/gtest.h>

#include <string>

namespace pete::core {
namespace {

std::string error_of(const Config& c) {
  const char* e = config_error(c);
  return e == nullptr ? "" : e;
}

TEST(Config, TheShippedRobotIsValid) {
  EXPECT_EQ(config_error(kRobotConfig), nullptr);
  EXPECT_EQ(ports_error(kRobotPorts), nullptr);
  // The protocol's defaults: State at 50 Hz, Commands valid 250 ms.
  EXPECT_EQ(kRobotConfig.link.state_period_ms, 20u);
  EXPECT_EQ(kRobotConfig.link.default_command_valid_ms, 250u);
  EXPECT_TRUE(kRobotConfig.jetson_drives_in_autonomous);
  EXPECT_TRUE(kRobotConfig.jetson_drives_in_driver);
}

TEST(Config, NamesWhatIsWrong) {
  Config c = kRobotConfig;
  c.drive.wheel_diameter_m = 0.0f;
  EXPECT_EQ(error_of(c), "wheel_diameter_m out of range");
  c = kRobotConfig;
  c.drive.cartridge_rpm = 300.0f;
  EXPECT_EQ(error_of(c), "cartridge_rpm must be 100, 200 or 600");
  c = kRobotConfig;
  c.drive.max_speed_fraction = 1.5f;
  EXPECT_EQ(error_of(c), "max_speed_fraction must be in (0, 1]");
  c = kRobotConfig;
  c.link.state_period_ms = 15;
  EXPECT_EQ(error_of(c), "state_period_ms must be a multiple of loop_period_ms");
  c = kRobotConfig;
  c.link.default_command_valid_ms = 5000;
  EXPECT_EQ(error_of(c), "default_command_valid_ms must be in 1..max_command_valid_ms");
  c = kRobotConfig;
  c.loop_period_ms = 1;
  EXPECT_EQ(error_of(c), "loop_period_ms must be 2..50");
  c = kRobotConfig;
  c.drive.gear_ratio = -1.0f;
  EXPECT_EQ(error_of(c), "gear_ratio out of range");
  c = kRobotConfig;
  c.driver.deadband = 0.7f;
  EXPECT_EQ(error_of(c), "driver deadband must be in [0, 0.5)");
  c = kRobotConfig;
  c.alliance = static_cast<msg::Alliance>(9);
  EXPECT_EQ(error_of(c), "alliance is not a valid Alliance");
  c = kRobotConfig;
  c.clamp.confirm_ms = 5000;
  EXPECT_EQ(error_of(c), "clamp confirm_ms must be at most 1000");
}

TEST(Config, PortsMustBeDistinctAndInRange) {
  Ports p = kRobotPorts;
  p.right[1] = -1;  // port 1 is already a (reversed) left motor
  EXPECT_STREQ(ports_error(p), "a port is used twice");
  p = kRobotPorts;
  p.intake[0] = 22;
  EXPECT_STREQ(ports_error(p), "motor port out of range 1..21");
  p = kRobotPorts;
  p.gps = p.intake[0];
  EXPECT_STREQ(ports_error(p), "the gps port is also a motor port");
  p = kRobotPorts;
  p.left[0] = 0;
  EXPECT_STREQ(ports_error(p), "each drive side needs at least one motor");
}

TEST(Config, ClampPortsAreAdiPorts) {
  EXPECT_EQ(kRobotPorts.clamp_piston, 0) << "shipped without a clamp, like the ring counter";
  EXPECT_EQ(kRobotPorts.clamp_sensor, 0);
  EXPECT_TRUE(kRobotConfig.clamp.auto_close);
  Ports p = kRobotPorts;
  p.clamp_piston = 'A';
  p.clamp_sensor = 2;
  EXPECT_EQ(ports_error(p), nullptr);
  p.clamp_sensor = 'b';
  EXPECT_EQ(ports_error(p), nullptr);
  p.clamp_sensor = 'I';
  EXPECT_STREQ(ports_error(p), "clamp ADI ports must be 0, 1..8 or 'A'..'H'");
  p.clamp_sensor = 9;
  EXPECT_STREQ(ports_error(p), "clamp ADI ports must be 0, 1..8 or 'A'..'H'");
  p.clamp_sensor = 1;
  EXPECT_STREQ(ports_error(p), "the clamp piston and sensor share an ADI port");
  p.clamp_piston = 0;
  p.clamp_sensor = 'B';
  EXPECT_STREQ(ports_error(p), "a clamp sensor needs a clamp");
  p.clamp_piston = 'H';
  p.clamp_sensor = 0;
  EXPECT_EQ(ports_error(p), nullptr) << "a piston alone: the driver's button only";
  EXPECT_EQ(adi_port_index('a'), 1);
  EXPECT_EQ(adi_port_index('H'), 8);
  EXPECT_EQ(adi_port_index(0), 0);
}

}  // namespace
}  // namespace pete::core
