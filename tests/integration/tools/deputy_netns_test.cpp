// Deputies on two hosts and a sheriff (docs/launcher.md "Several hosts"): two
// network namespaces joined by a veth pair are two hosts on one network, with
// nothing leaving this machine. Each host runs harvest-launch --deputy for its
// group with LCM at ttl=1, so the traffic between them crosses the veth. Needs
// root (ip netns); skipped otherwise. The namespaces are deleted and every
// process started is stopped by its pid, also when a check fails.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "test_support.hpp"
#include "two_host_net.hpp"

namespace harvest {
namespace {

using namespace std::chrono_literals;
using namespace harvest::testing::two_hosts;
using testing::ChildProcess;
using testing::eventually;
namespace fs = std::filesystem;

const std::string kFixtures = testing::source_path("tests/integration/tools/fixtures");

TEST(Deputies, TheSheriffSeesBothHostsKillsRestartsStopsAndStartsRemoteProcesses) {
  TwoHostNet net;
  if (!net.ok()) GTEST_SKIP() << "needs root and ip netns (network namespaces)";
  testing::TempDir dir;
  const std::string url = ttl1_url();
  const std::string sleeper = kFixtures + "/sleeper.sh";
  const auto set = dir / "set.yaml";
  std::ofstream(set) << "name: two-hosts\nprocesses:\n"
                     << "  - {name: a1, command: " << sleeper << ", args: [a1], harvest_options: false, group: ga}\n"
                     << "  - {name: a2, command: " << STANDIN_EXE << ", args: [--no-netcheck], group: ga}\n"
                     << "  - {name: b1, command: " << STANDIN_EXE << ", args: [--no-netcheck], group: gb}\n"
                     << "  - {name: b2, command: " << sleeper << ", args: [b2], harvest_options: false, group: gb,\n"
                     << "     restart: {policy: always, backoff_s: 0.2}}\n";
  const std::vector<std::string> env{"PID_DIR=" + dir.path().string()};
  auto deputy = [&](const std::string& ns, const std::string& name, const std::string& group) {
    return std::make_unique<ChildProcess>(net.in(ns, {testing::bin("harvest-launch"), set.string(), "--deputy", name,
                                                      "--group", group, "--lcm-url", url, "--no-table"}),
                                          dir / (name + ".out"), env);
  };
  auto dep_a = deputy(net.a(), "hv-a", "ga");
  auto dep_b = deputy(net.b(), "hv-b", "gb");
  auto sheriff = std::make_unique<ChildProcess>(
      net.in(net.a(), {testing::bin("harvest-launch"), "--sheriff", "--lcm-url", url, "--no-table"}),
      dir / "sheriff.out");
  const auto sheriff_in_a = [&](std::vector<std::string> args, const std::string& name,
                                std::chrono::milliseconds timeout = 30s) {
    std::vector<std::string> argv{testing::bin("harvest-launch"), "--sheriff", "--lcm-url", url};
    argv.insert(argv.end(), args.begin(), args.end());
    return run(net.in(net.a(), argv), dir / (name + ".out"), timeout);
  };

  // The sheriff in host a sees both hosts' processes, and host b's output.
  ASSERT_TRUE(eventually(
      [&] {
        const std::string o = sheriff->output();
        return reported_pid(o, "hv-a/a1") > 0 && reported_pid(o, "hv-a/a2") > 0 && reported_pid(o, "hv-b/b1") > 0 &&
               reported_pid(o, "hv-b/b2") > 0;
      },
      30s))
      << sheriff->output() << dep_a->output() << dep_b->output();
  EXPECT_TRUE(eventually([&] { return sheriff->output().find("[hv-b/b2] b2 up") != std::string::npos; }, 10s))
      << sheriff->output();
  const int b2 = reported_pid(sheriff->output(), "hv-b/b2");
  EXPECT_EQ(net_ns_of(b2), net_ns_of(dep_b->pid()));  // it runs on host b
  EXPECT_NE(net_ns_of(b2), net_ns_of(sheriff->pid()));
  const Ran list = sheriff_in_a({"--list", "--wait", "2.5"}, "list");
  EXPECT_EQ(list.code, 0) << list.out;
  EXPECT_TRUE(std::regex_search(list.out, std::regex("\nhv-a +a2 +ga +running"))) << list.out;
  EXPECT_TRUE(std::regex_search(list.out, std::regex("\nhv-b +b2 +gb +running"))) << list.out;

  // Killed on host b: its deputy restarts it per policy, the sheriff sees the new pid.
  ASSERT_EQ(kill(b2, SIGKILL), 0);
  ASSERT_TRUE(eventually([&] { return reported_pid(sheriff->output(), "hv-b/b2") != b2; }, 15s)) << sheriff->output();
  const int b2_again = reported_pid(sheriff->output(), "hv-b/b2");
  EXPECT_TRUE(alive(b2_again));
  EXPECT_NE(dep_b->output().find("b2 killed by signal 9"), std::string::npos) << dep_b->output();

  // Restarted on order from host a.
  const Ran restart = sheriff_in_a({"--restart", "hv-b/b2"}, "restart");
  ASSERT_EQ(restart.code, 0) << restart.out << dep_b->output();
  std::smatch m;
  ASSERT_TRUE(std::regex_search(restart.out, m, std::regex("restarted hv-b/b2: pid (\\d+) -> pid (\\d+)")))
      << restart.out;
  EXPECT_EQ(std::stoi(m[1]), b2_again);
  const int b2_ordered = std::stoi(m[2]);
  EXPECT_FALSE(alive(b2_again));
  EXPECT_TRUE(alive(b2_ordered));
  EXPECT_NE(dep_b->output().find("b2 got SIGTERM"), std::string::npos) << dep_b->output();  // stopped cleanly

  // An order signed with another key is refused, counted and said; nothing restarts.
  const fs::path other_key = dir / "other.key";
  ASSERT_EQ(sh(testing::bin("harvest-keygen") + " " + other_key.string()), 0);
  const Ran forged = sheriff_in_a({"--restart", "hv-b/b2", "--key", other_key.string(), "--timeout", "4"}, "forged");
  EXPECT_EQ(forged.code, 1) << forged.out;
  EXPECT_NE(forged.out.find("it refused the order"), std::string::npos) << forged.out;
  EXPECT_TRUE(alive(b2_ordered));
  EXPECT_TRUE(eventually([&] { return sheriff->output().find("deputy hv-b refused") != std::string::npos; }, 5s))
      << sheriff->output();

  // Stopped on order (not restarted by its policy), then started again.
  const Ran stop = sheriff_in_a({"--stop", "hv-b/b2"}, "stop");
  ASSERT_EQ(stop.code, 0) << stop.out << dep_b->output();
  EXPECT_FALSE(alive(b2_ordered));
  std::this_thread::sleep_for(1s);  // longer than its back-off: a policy restart would have happened
  EXPECT_TRUE(eventually([&] { return sheriff->output().find("hv-b/b2 stopped (no pid)") != std::string::npos; }, 5s))
      << sheriff->output();
  const Ran start = sheriff_in_a({"--start", "hv-b/b2"}, "start");
  ASSERT_EQ(start.code, 0) << start.out;
  ASSERT_TRUE(std::regex_search(start.out, m, std::regex("started hv-b/b2: pid (\\d+)"))) << start.out;
  const int b2_started = std::stoi(m[1]);
  EXPECT_TRUE(alive(b2_started));
  EXPECT_EQ(net_ns_of(b2_started), net_ns_of(dep_b->pid()));

  // A deputy that stops is lost to the sheriff; the deputies stop their processes.
  const int a1 = reported_pid(sheriff->output(), "hv-a/a1");
  EXPECT_EQ(dep_b->stop(10s), 0) << dep_b->output();
  EXPECT_FALSE(alive(b2_started));
  EXPECT_TRUE(eventually([&] { return sheriff->output().find("deputy hv-b lost") != std::string::npos; }, 10s))
      << sheriff->output();
  EXPECT_EQ(dep_a->stop(10s), 0) << dep_a->output();
  EXPECT_FALSE(alive(a1));
  EXPECT_EQ(sheriff->stop(5s), 0) << sheriff->output();
}

}  // namespace
}  // namespace harvest
