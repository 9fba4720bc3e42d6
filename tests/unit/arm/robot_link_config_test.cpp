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
