// The controller and the robot link read one envelope (config/arm/envelope.yaml):
// the same speed and acceleration limits, and a controller workspace box
// outside the link's is refused when the controller starts.
#include <gtest/gtest.h>

#include <fstream>

#include "arm/robot_link_node.hpp"
#include "servo/servo_config.hpp"
#include "test_support.hpp"

namespace harvest {
namespace {

servo::ServoConfig controller(const std::string& override_a = "", const std::string& override_b = "") {
  auto doc = config::Document::load_file("config/servo/controller.yaml");
  if (!override_a.empty()) doc.apply_override(override_a);
  if (!override_b.empty()) doc.apply_override(override_b);
  return servo::ServoConfig::from_yaml(doc.root());
}

arm::RobotLinkConfig link_config(const std::string& override_a = "") {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  if (!override_a.empty()) doc.apply_override(override_a);
  return arm::RobotLinkConfig::from_config(doc.root());
}

std::string controller_error(const std::string& a, const std::string& b = "") {
  try {
    controller(a, b);
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(Envelope, ControllerAndLinkShareTheShippedLimitsAndBox) {
  const auto c = controller();
  const auto l = link_config();
  EXPECT_EQ(c.max_linear_speed, l.limits.linear_speed);
  EXPECT_EQ(c.max_angular_speed, l.limits.angular_speed);
  EXPECT_EQ(c.max_linear_accel, l.limits.linear_acceleration);
  EXPECT_EQ(c.max_angular_accel, l.limits.angular_acceleration);
  EXPECT_TRUE((c.workspace.min.array() >= l.workspace.min.array()).all());
  EXPECT_TRUE((c.workspace.max.array() <= l.workspace.max.array()).all());
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

// The box the controller had before the envelope (x to 0.8, y to 1.4): goals
// the link refuses. Refused at start, naming both boxes and the envelope file.
TEST(Envelope, ControllerBoxExceedingTheLinksIsRefusedAtStart) {
  EXPECT_EQ(controller_error("workspace.max=[0.7, 1.3, 0.3]"), "");  // the link's own faces: inside
  const std::string e = controller_error("workspace.max=[0.8, 1.4, 0.3]");
  EXPECT_NE(e.find("workspace: expected a box inside the robot envelope's [-0.9, 0.3, -1.1]..[0.7, 1.3, 0.3]"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("envelope.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("got [-0.9, 0.3, -1]..[0.8, 1.4, 0.3]"), std::string::npos) << e;
  EXPECT_NE(controller_error("workspace.min=[-1.0, 0.3, -1.0]"), "") << "below the link's x";
  EXPECT_NE(controller_error("workspace.min=[-0.9, 0.3, -1.2]"), "") << "below the link's z";
}

}  // namespace
}  // namespace harvest
