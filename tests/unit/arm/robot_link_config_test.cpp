// The robot link's and the simulated drives' configuration: what
// --check-config must refuse before a process touches a bus, and the shipped
// bus strings keeping the virtual CAN bus on this host.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <functional>
#include <string>

#include "arm/robot_link_node.hpp"
#include "can/bus_spec.hpp"
#include "simdrive/sim_drives_node.hpp"

namespace harvest::arm {
namespace {

std::string error_of(const std::function<void()>& load) {
  try {
    load();
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

config::Document robot_link_file(const std::string& overrides) {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  if (!overrides.empty()) doc.apply_override(overrides);
  return doc;
}

TEST(RobotLinkConfig, ShippedFileLoads) {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  const auto c = RobotLinkConfig::from_config(doc.root());
  doc.check_unused();
  EXPECT_EQ(can::parse_bus_spec(c.bus).udp.hop_limit, 0);
  EXPECT_LE(c.limits.default_validity, c.limits.max_validity);
}

// A robot's own hand-eye calibration replaces the arm model's camera: the camera sits in the flange frame at
// tool x file, as the model's `camera.calibration` puts it. The simulated robot's measured file against the
// hand-measured one the model reads: translations as in the files, in the tool frame. A missing file is refused
// at load, naming the key and the file.
TEST(RobotLinkConfig, ARobotsOwnHandEyeReplacesTheArmModelsCamera) {
  auto shipped = robot_link_file("");
  const auto model = RobotLinkConfig::from_config(shipped.root()).model;
  auto own = robot_link_file("hand_eye=../cameras/hand_eye_sim.yaml");
  const auto c = RobotLinkConfig::from_config(own.root());
  own.check_unused();
  const Eigen::Vector3d model_cam = (model.tool.inverse() * model.camera).translation() * 1e3;
  const Eigen::Vector3d own_cam = (c.model.tool.inverse() * c.model.camera).translation() * 1e3;
  EXPECT_NEAR((model_cam - Eigen::Vector3d(15, -10, -40)).norm(), 0.0, 1e-9) << model_cam.transpose();
  EXPECT_NEAR((own_cam - Eigen::Vector3d(14.8327733737, -10.5480609998, -48.0772345987)).norm(), 0.0, 1e-6)
      << own_cam.transpose();
  EXPECT_GT(Eigen::AngleAxisd((c.model.tool.inverse() * c.model.camera).rotation()).angle(), 0.03);  // 1.8 deg
  EXPECT_EQ(c.model.joints.size(), model.joints.size());  // the rest is the model's

  auto missing = robot_link_file("hand_eye=../cameras/nothere.yaml");
  const std::string e = error_of([&] { RobotLinkConfig::from_config(missing.root()); });
  EXPECT_NE(e.find("hand_eye"), std::string::npos) << e;
  EXPECT_NE(e.find("nothere.yaml"), std::string::npos) << e;
}

TEST(RobotLinkConfig, DefaultValidityLongerThanTheMaximumIsRefused) {
  auto doc = robot_link_file("limits.max_validity_ms=50");  // the file's default is 100 ms
  const std::string e = error_of([&] { RobotLinkConfig::from_config(doc.root()); });
  EXPECT_NE(e.find("default_validity_ms"), std::string::npos) << e;
  EXPECT_NE(e.find("no longer than max_validity_ms (50 ms)"), std::string::npos) << e;
  auto same = robot_link_file("limits.max_validity_ms=100");
  EXPECT_NO_THROW(RobotLinkConfig::from_config(same.root()));
}

TEST(RobotLinkConfig, UnknownBusTransportIsRefused) {
  for (const std::string bus : {"canbus:can0", "udp_multicast:10.1.2.3:43113", "udp_multicast:239.1.2.3:1?ttl=300"}) {
    auto doc = robot_link_file("bus=" + bus);
    const std::string e = error_of([&] { RobotLinkConfig::from_config(doc.root()); });
    EXPECT_NE(e.find("bus"), std::string::npos) << bus << ": " << e;
    EXPECT_NE(e.find(bus), std::string::npos) << "names the string: " << e;
  }
  auto sim = config::Document::load_file("config/arm/sim_drives.yaml");
  sim.apply_override("bus=socket_can:can0");
  const std::string e = error_of([&] { simdrive::SimDrivesConfig::from_config(sim.root()); });
  EXPECT_NE(e.find("unknown transport 'socket_can'"), std::string::npos) << e;
}

// Every CAN bus string in config/ (the robot link's, the simulated drives',
// the simulator's) is valid, and a virtual bus stays on this host (TTL 0):
// the simulator, the demo and the tests must not put CAN frames on a LAN.
TEST(ShippedConfig, EveryVirtualCanBusIsThisHostOnly) {
  int found = 0;
  std::function<void(const YAML::Node&, const std::string&)> visit = [&](const YAML::Node& n, const std::string& f) {
    if (n.IsMap()) {
      for (const auto& kv : n) {
        if (kv.first.as<std::string>() == "bus" && kv.second.IsScalar()) {
          ++found;
          const auto spec = can::parse_bus_spec(kv.second.as<std::string>());
          if (spec.kind == can::BusSpec::Kind::kUdpMulticast) {
            EXPECT_EQ(spec.udp.hop_limit, 0) << f << ": " << kv.second.as<std::string>();
          }
        }
        visit(kv.second, f);
      }
    } else if (n.IsSequence()) {
      for (const auto& c : n) visit(c, f);
    }
  };
  for (const auto& e : std::filesystem::recursive_directory_iterator("config"))
    if (e.path().extension() == ".yaml") visit(YAML::LoadFile(e.path().string()), e.path().string());
  EXPECT_GE(found, 2) << "robot_link.yaml and sim_drives.yaml name a bus";
}

}  // namespace
}  // namespace harvest::arm
