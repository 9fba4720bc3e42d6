// The controller and the robot link read one envelope (config/arm/envelope.yaml):
// the same speed and acceleration limits.
#include <gtest/gtest.h>

#include <fstream>

#include "arm/robot_link_node.hpp"
#include "servo/servo_config.hpp"
#include "test_support.hpp"

namespace harvest {
namespace {

servo::ServoConfig controller(const std::string& override_a = "", const std::string& override_b = "") {
  auto doc = config::Document::load_file(HARVEST_SOURCE_DIR "/config/servo/controller.yaml");
  if (!override_a.empty()) doc.apply_override(override_a);
  if (!override_b.empty()) doc.apply_override(override_b);
  return servo::ServoConfig::from_yaml(doc.root());
}

arm::RobotLinkConfig link_config(const std::string& override_a = "") {
  auto doc = config::Document::load_file(HARVEST_SOURCE_DIR "/config/arm/robot_link.yaml");
  if (!override_a.empty()) doc.apply_override(override_a);
  return arm::RobotLinkConfig::from_config(doc.root());
}

TEST(Envelope, ControllerAndLinkShareTheShippedLimits) {
  const auto c = controller();
  const auto l = link_config();
  EXPECT_EQ(c.max_linear_speed, l.limits.linear_speed);
  EXPECT_EQ(c.max_angular_speed, l.limits.angular_speed);
  EXPECT_EQ(c.max_linear_accel, l.limits.linear_acceleration);
  EXPECT_EQ(c.max_angular_accel, l.limits.angular_acceleration);
}

// One file: a slower envelope slows both.
TEST(Envelope, OneFileSetsBothProcessesLimits) {
  harvest::testing::TempDir dir;
  const auto file = dir / "envelope.yaml";
  std::ofstream(file) << "workspace: {min: [-0.9, 0.3, -1.1], max: [0.7, 1.3, 0.3]}\n"
                         "max_linear_speed: 0.2\nmax_angular_speed: 1.0\n"
                         "max_linear_acceleration: 1.0\nmax_angular_acceleration: 2.0\n";
  // The controller's IR approach speed may not exceed its linear speed limit.
  const auto c = controller("envelope=" + file.string(), "ir_approach_speed=0.2");
  const auto l = link_config("envelope=" + file.string());
  EXPECT_EQ(c.max_linear_speed, 0.2);
  EXPECT_EQ(l.limits.linear_speed, 0.2);
  EXPECT_EQ(c.max_angular_accel, 2.0);
  EXPECT_EQ(l.limits.angular_acceleration, 2.0);
}

}  // namespace
}  // namespace harvest
