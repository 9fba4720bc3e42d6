// Site files: substitution into the field sets, and the device checks against
// a fake /sys/class/net and real device nodes.
#include "launch/site_check.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_support.hpp"

namespace harvest::launch {
namespace {

// A network interface as /sys/class/net shows it.
void fake_interface(const std::filesystem::path& net, const std::string& name, int type, unsigned flags,
                    const std::string& operstate) {
  std::filesystem::create_directories(net / name);
  std::ofstream(net / name / "type") << type << "\n";
  std::ofstream(net / name / "flags") << "0x" << std::hex << flags << "\n";
  std::ofstream(net / name / "operstate") << operstate << "\n";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(SiteCheck, CanInterfaceMissingNotCanDownNoLinkAndUp) {
  testing::TempDir dir;
  const auto net = dir / "net";
  fake_interface(net, "can0", 280, 0x1, "up");            // up
  fake_interface(net, "can1", 280, 0x0, "down");          // down
  fake_interface(net, "can2", 280, 0x1, "down");          // up, bus-off
  fake_interface(net, "eth0", 1, 0x1003, "up");           // Ethernet
  fake_interface(net, "vcan0", 280, 0xc1, "unknown");     // virtual CAN: up, no carrier notion
  EXPECT_EQ(check_can_interface("can0", net), "");
  EXPECT_EQ(check_can_interface("vcan0", net), "");
  const std::string missing = check_can_interface("can9", net);
  EXPECT_TRUE(contains(missing, "CAN interface can9 does not exist on this machine")) << missing;
  const std::string down = check_can_interface("can1", net);
  EXPECT_TRUE(contains(down, "is down: `sudo ip link set can1 up type can bitrate 1000000")) << down;
  EXPECT_TRUE(contains(check_can_interface("can2", net), "up but has no link (bus-off"));
  EXPECT_TRUE(contains(check_can_interface("eth0", net), "eth0 is not a CAN interface (link type 1"));
}

TEST(SiteCheck, DeviceNodeMissingDanglingNotADeviceAndPermissions) {
  testing::TempDir dir;
  const auto always = [](const std::filesystem::path&) { return true; };
  const auto never = [](const std::filesystem::path&) { return false; };
  EXPECT_EQ(check_device_node("/dev/null", "ee_serial", always), "");
  EXPECT_EQ(check_device_node("/dev/null", "ee_serial", {}), "");  // the real access() check

  const std::string cam = check_device_node(dir / "camera-fixed", "camera_fixed", always);
  EXPECT_TRUE(contains(cam, "camera-fixed does not exist")) << cam;
  EXPECT_TRUE(contains(cam, "ls -l /dev/v4l/by-id/")) << cam;
  const std::string ser = check_device_node("/dev/serial/by-id/usb-nothing-if00-port0", "ee_serial", always);
  EXPECT_TRUE(contains(ser, "ls -l /dev/serial/by-id/")) << ser;

  std::filesystem::create_symlink(dir / "video7", dir / "camera-hand");  // a udev link left by an unplugged camera
  const std::string dangling = check_device_node(dir / "camera-hand", "camera_hand", always);
  EXPECT_TRUE(contains(dangling, "is a link to " + (dir / "video7").string() + ", which does not exist")) << dangling;

  std::ofstream(dir / "plain") << "x";
  EXPECT_TRUE(contains(check_device_node(dir / "plain", "ee_serial", always), "is not a device node"));

  // /dev/null belongs to group root, which a test run as root is in; a user
  // outside the node's group is told which group to join.
  const std::string denied = check_device_node("/dev/null", "ee_serial", never);
  EXPECT_TRUE(contains(denied, "cannot be opened for reading and writing by")) << denied;
}

SetSpec field_set(const testing::TempDir& dir, const std::string& site_yaml, const SiteOverrides& over = {}) {
  std::ofstream(dir / "site.yaml") << site_yaml;
  std::ofstream(dir / "set.yaml") << "site: site.yaml\nprocesses:\n"
                                     "  - {name: link, command: x, args: [--set, 'bus=${can_bus}'], group: robot}\n"
                                     "  - {name: ee, command: x, args: [--set, 'port=${ee_serial}'], group: robot}\n"
                                     "  - {name: cam, command: x, env: {DEV: '${camera}'}, group: vision}\n"
                                     "  - {name: cam2, command: x, args: ['${camera}'], group: vision}\n";
  return load_set(dir / "set.yaml", {}, over);
}

TEST(SiteCheck, SetSubstitutesSiteValuesAndChecksOnlyTheSelectedGroup) {
  testing::TempDir dir;
  const auto net = dir / "net";
  fake_interface(net, "can0", 280, 0x0, "down");
  const std::string cam = "/dev/harvest-test/no-such-camera";  // only /dev paths are device nodes to check
  const SetSpec s = field_set(dir, "can_bus: socketcan:can0\nee_serial: /dev/null\ncamera: " + cam + "\n");
  EXPECT_EQ(s.processes[0].args, (std::vector<std::string>{"--set", "bus=socketcan:can0"}));
  EXPECT_EQ(s.processes[2].env.at("DEV"), cam);
  EXPECT_EQ(s.site.used_by.at("cam2"), std::vector<std::string>{"camera"});

  HostProbe probe;
  probe.sys_class_net = net;
  const auto robot = check_site(s, select_group(s, "robot"), probe);
  ASSERT_EQ(robot.size(), 1u);
  EXPECT_TRUE(contains(robot[0], "link: site can_bus = socketcan:can0: CAN interface can0 is down")) << robot[0];
  const auto vision = check_site(s, select_group(s, "vision"), probe);
  ASSERT_EQ(vision.size(), 1u);  // two processes share the camera: one line
  EXPECT_TRUE(contains(vision[0], "cam: site camera = " + cam + ": ")) << vision[0];
  EXPECT_TRUE(contains(vision[0], "does not exist")) << vision[0];

  // The command line overrides one value: a virtual bus is not checked.
  SiteOverrides over;
  std::vector<std::string> rest;
  split_site_overrides({"site.can_bus=udp_multicast:239.74.163.2:43113?ttl=0", "recording.enabled=true"}, rest,
                       over);
  const SetSpec v = field_set(dir, "can_bus: socketcan:can0\nee_serial: /dev/null\ncamera: /dev/null\n", over);
  EXPECT_EQ(v.processes[0].args[1], "bus=udp_multicast:239.74.163.2:43113?ttl=0");
  EXPECT_TRUE(check_site(v, select_group(v, ""), probe).empty());
}

TEST(SiteCheck, SplitsSiteOverridesFromSetOverrides) {
  std::vector<std::string> set;
  SiteOverrides site;
  split_site_overrides({"site.can_bus=socketcan:can1", "recording.enabled=true", "site=../site/x.yaml"}, set, site);
  EXPECT_EQ(site.assignments, std::vector<std::string>{"can_bus=socketcan:can1"});
  EXPECT_EQ(set, (std::vector<std::string>{"recording.enabled=true", "site=../site/x.yaml"}));
}

// ${KEY:-DEFAULT}: a choice with a sound default (the detector mode) need not
// be in every robot's site file; the site's value wins when it is.
TEST(SiteCheck, ADefaultStandsInForAMissingSiteValue) {
  testing::TempDir dir;
  std::ofstream(dir / "site.yaml") << "camera: /dev/null\n";
  std::ofstream(dir / "set.yaml")
      << "site: site.yaml\nprocesses:\n"
         "  - {name: det, command: x, args: ['mode=${mode:-learned}', '${camera:-/dev/zero}']}\n";
  const SetSpec s = load_set(dir / "set.yaml");
  EXPECT_EQ(s.processes[0].args, (std::vector<std::string>{"mode=learned", "/dev/null"}));
  SiteOverrides over;
  over.assignments = {"mode=canopy"};
  EXPECT_EQ(load_set(dir / "set.yaml", {}, over).processes[0].args[0], "mode=canopy");
}

TEST(SiteCheck, RefusesUnknownKeysAndBadSiteFilesClearly) {
  testing::TempDir dir;
  auto error = [&](const std::string& site_yaml, const SiteOverrides& over = {}) -> std::string {
    try {
      field_set(dir, site_yaml, over);
    } catch (const config::Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string unknown = error("can_bus: socketcan:can0\nee_serial: /dev/null\n");
  EXPECT_TRUE(contains(unknown, "processes[2].env.DEV: ${camera} is not a site value (not in ")) << unknown;
  EXPECT_TRUE(contains(unknown, "--set site.camera=VALUE")) << unknown;
  const std::string nested = error("can_bus: {a: 1}\n");
  EXPECT_TRUE(contains(nested, "can_bus: expected a single value")) << nested;
  SiteOverrides dotted;
  dotted.assignments = {"a.b=1"};
  EXPECT_TRUE(contains(error("can_bus: x\n", dotted), "expected site.KEY=VALUE"));

  // A set without a site file names what to do.
  std::ofstream(dir / "bare.yaml") << "processes: [{name: a, command: x, args: ['${can_bus}']}]\n";
  try {
    load_set(dir / "bare.yaml");
    ADD_FAILURE() << "a set using a site value without a site was accepted";
  } catch (const config::Error& e) {
    EXPECT_TRUE(contains(e.what(), "the set names no site file; give `site:` in the set or harvest-launch --site FILE"))
        << e.what();
  }
  // --site FILE replaces the set's site file.
  std::ofstream(dir / "other.yaml") << "can_bus: socketcan:can7\nee_serial: /dev/null\ncamera: /dev/null\n";
  SiteOverrides other;
  other.file = dir / "other.yaml";
  const SetSpec s = field_set(dir, "can_bus: socketcan:can0\n", other);
  EXPECT_EQ(s.processes[0].args[1], "bus=socketcan:can7");
  EXPECT_EQ(s.site.file, dir / "other.yaml");
}

// The shipped field sets take every device from the shipped site file.
TEST(SiteCheck, ShippedFieldSetsUseTheSiteFile) {
  const SetSpec robot = load_set(testing::source_path("config/sets/field-robot.yaml"));
  EXPECT_EQ(robot.site.values.at("can_bus"), "socketcan:can0");
  EXPECT_EQ(robot.processes[0].args,
            (std::vector<std::string>{"--config", "config/arm/robot_link.yaml", "--set", "bus=socketcan:can0", "--set",
                                      "authority.key=/etc/harvest/robot.key"}));
  EXPECT_EQ(robot.site.used_by.at("ee-bridge"), (std::vector<std::string>{"ee_serial", "command_key"}));
  EXPECT_EQ(robot.site.used_by.at("servo-controller"), std::vector<std::string>{"command_key"});
  const SetSpec vision = load_set(testing::source_path("config/sets/field-vision.yaml"));
  EXPECT_EQ(vision.site.used_by.at("camera-fixed"), std::vector<std::string>{"camera_fixed"});
  EXPECT_EQ(vision.site.used_by.at("camera-hand"), std::vector<std::string>{"camera_hand"});
  EXPECT_EQ(vision.processes[2].args.back(), "detector.mode=learned");  // the network on the canopy view
  EXPECT_EQ(vision.processes[3].args.back(), "detector.mode=canopy");
}

}  // namespace
}  // namespace harvest::launch
