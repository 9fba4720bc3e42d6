// A harvest through two deputies (docs/launcher.md "Several hosts"): the sim
// set split over two network namespaces joined by a veth pair, LCM at ttl=1.
// Needs root (ip netns); skipped otherwise. Separate from deputy_netns_test
// because it runs the whole process set (about a minute).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <thread>

#include "two_host_net.hpp"

namespace harvest {
namespace {

using namespace std::chrono_literals;
using namespace harvest::testing::two_hosts;
using testing::ChildProcess;
using testing::eventually;
namespace fs = std::filesystem;

// The sim set split over two hosts: host a runs the simulator and the robot
// (sim, robot link, end-effector bridge, servo controller), host b the vision
// (detectors, reconstructor): cameras go a -> b over the veth, targets b -> a.
// The operator's START is sent on host a; the simulator ends the run when the
// fruit is decided, which ends host a's set.
TEST(Deputies, AHarvestRunsThroughTwoDeputiesAgainstTheSimulator) {
  TwoHostNet net;
  if (!net.ok()) GTEST_SKIP() << "needs root and ip netns (network namespaces)";
  testing::TempDir dir;
  const std::string url = ttl1_url();
  // The shipped set, its relative paths made absolute so the copy can live in the test's folder.
  const fs::path sets = testing::source_path("config/sets");
  YAML::Node root = YAML::LoadFile((sets / "sim.yaml").string());
  root["bin_dir"] = fs::path(testing::bin("harvest-launch")).parent_path().string();
  root["site"] = fs::weakly_canonical(sets / root["site"].as<std::string>()).string();
  for (YAML::Node p : root["processes"]) {
    p["cwd"] = testing::source_path("");
    // A stall of the link on the loaded test machine must not trip the drives' 25 ms deadline (as the demo tests).
    if (p["name"].as<std::string>() == "robot-link")
      for (const char* a : {"--set", "can.drive_rpdo_timeout_ms=200", "--set", "can.drive_heartbeat_timeout_ms=300"})
        p["args"].push_back(a);
  }
  const auto set = dir / "set.yaml";
  YAML::Emitter yaml;
  yaml << root;
  std::ofstream(set) << yaml.c_str() << "\n";
  const std::string port = std::to_string(20000 + getpid() % 20000);
  const std::vector<std::string> site{"--set", "site.can_bus=udp_multicast:239.74.163.9:" + port + "?ttl=0", "--set",
                                      "site.board_port=" + std::to_string(40000 + getpid() % 20000)};
  auto deputy = [&](const std::string& ns, const std::string& name, const std::string& group) {
    std::vector<std::string> argv{testing::bin("harvest-launch"),
                                  set.string(),
                                  "--deputy",
                                  name,
                                  "--group",
                                  group,
                                  "--lcm-url",
                                  url,
                                  "--no-table"};
    argv.insert(argv.end(), site.begin(), site.end());
    return std::make_unique<ChildProcess>(net.in(ns, argv), dir / (name + ".out"));
  };
  const auto t0 = std::chrono::steady_clock::now();
  auto dep_b = deputy(net.b(), "hv-b", "vision");
  auto dep_a = deputy(net.a(), "hv-a", "sim,robot");
  auto sheriff = std::make_unique<ChildProcess>(
      net.in(net.b(), {testing::bin("harvest-launch"), "--sheriff", "--lcm-url", url, "--no-table"}),
      dir / "sheriff.out");
  // START until the controller obeys (it refuses while it has no robot state or targets yet).
  bool started = false;
  for (int i = 0; i < 20 && !started && dep_a->running(); ++i) {
    const Ran op = run(net.in(net.a(), {testing::bin("harvest-operator"), "start", "--lcm-url", url, "--timeout", "3"}),
                       dir / "operator.out", 10s);
    started = op.code == 0;
    if (!started) std::this_thread::sleep_for(1s);
  }
  ASSERT_TRUE(started) << dep_a->output() << dep_b->output();
  const int code = dep_a->wait(180s);  // the simulator ends the run, and with it host a's set
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("harvest through two deputies: %.0f s from start to the end of the run\n", seconds);
  EXPECT_EQ(code, 0) << dep_a->output();
  // The fruit was picked, as host b's sheriff saw it in host a's forwarded output.
  EXPECT_TRUE(eventually(
      [&] { return std::regex_search(sheriff->output(), std::regex("\\[hv-a/sim\\] .*fruit \\S+ picked")); }, 5s))
      << sheriff->output();
  EXPECT_NE(sheriff->output().find("hv-b/reconstructor running"), std::string::npos) << sheriff->output();
  EXPECT_EQ(dep_b->stop(15s), 0) << dep_b->output();
  EXPECT_EQ(sheriff->stop(5s), 0);
}

}  // namespace
}  // namespace harvest
