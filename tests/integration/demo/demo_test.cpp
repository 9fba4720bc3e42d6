// The README's main command end to end, short: harvest-demo runs
// the simulator and the real process set through harvest-launch over real LCM,
// starts the harvest, and scores the recorded log against the ground truth.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>

#include "demo/set_rewrite.hpp"
#include "demo_support.hpp"
#include "runtime/json.hpp"
#include "runtime/log_io.hpp"

namespace ht = harvest::testing;
namespace fs = std::filesystem;
namespace rt = harvest::rt;

namespace {

using ht::run_demo;
using ht::slurp;

TEST(Demo, ExperimentOneIsPickedThroughTheWholeProcessSet) {
  ht::TempDir dir;
  std::string out;
  // Recorded with the cameras at 5 of their 30 frames a second, in parts of 1 MB; drawn with seed 7 (a
  // one-seed tree benchmark: experiment I's fruit is placed by hand, the seed changes noise and looks).
  ASSERT_EQ(run_demo({"--set", "config/sets/sim-direct.yaml", "--scenario", "config/scenarios/experiment1.yaml",
                      "--image-rate", "5", "--split-mb", "1", "--seeds", "7"},
                     dir.path(), &out),
            0)
      << out;
  // Progress went through the harvest states, and the summary says picked.
  EXPECT_NE(out.find("IR_APPROACH"), std::string::npos) << out;
  EXPECT_NE(out.find("DETACH"), std::string::npos) << out;
  const std::string summary = slurp(dir / "summary.json");
  const auto j = rt::Json::parse(summary);
  EXPECT_EQ(j["picked"], 1) << summary;
  EXPECT_EQ(j["success_rate"], 1.0) << summary;
  EXPECT_EQ(summary, slurp(dir / "out" / "summary.json"));
  ASSERT_EQ(j["per_run"].size(), 1u) << summary;
  EXPECT_EQ(j["per_run"][0]["seed"], 7);
  EXPECT_EQ(j["per_run"][0]["reachable"], 1);
  EXPECT_EQ(j["per_run"][0]["picked"], 1);
  EXPECT_NE(slurp(dir / "out" / "run0-set.yaml").find("seed=7"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "out" / "report.md"));

  // The launcher's recording holds the whole graph's traffic, in parts (the
  // summary above was scored from all of them), the cameras at 5 per second.
  std::vector<fs::path> parts;
  for (const auto& e : fs::directory_iterator(dir / "out"))
    if (e.path().filename().string().rfind("run0-", 0) == 0 && e.path().string().find(".lcm") != std::string::npos)
      parts.push_back(e.path());
  ASSERT_GE(parts.size(), 2u) << out;
  std::map<std::string, int> count;
  int64_t first = 0, last = 0;
  for (const auto& p : parts) {
    EXPECT_LE(fs::file_size(p), 1024 * 1024 + 2'000'000) << p;  // 1 MB, plus at most one frame beyond
    for (const auto& r : harvest::rt::read_log(p.string())) {
      ++count[r.channel];
      first = first == 0 ? r.timestamp : std::min(first, r.timestamp);
      last = std::max(last, r.timestamp);
    }
  }
  for (const char* c :
       {"CAMERA_FIXED", "CAMERA_HAND", "FRUIT_FIXED", "FRUIT_HAND", "TARGETS", "ROBOT_STATE", "ROBOT_COMMAND",
        "IR_RANGE", "GRIPPER_COMMAND", "HARVEST_STATUS", "SIM_TRUTH", "OPERATOR_COMMAND", "PROCESS_STATUS"})
    EXPECT_TRUE(count.count(c)) << "no " << c << " in run0";
  const double seconds = (last - first) / 1e6;
  EXPECT_LE(count["CAMERA_FIXED"], 5 * seconds + 2) << seconds << " s";
  // The detector saw every frame: far more detections than recorded frames.
  EXPECT_GT(count["FRUIT_FIXED"], 3 * count["CAMERA_FIXED"]) << count["FRUIT_FIXED"];
  // The recorder's reports reached the terminal.
  EXPECT_NE(out.find("[recorder] recording to "), std::string::npos) << out;
}

// A fresh recording of the demo replays with `harvest-replay LOG` alone:
// every process published its journal (JOURNAL: what each node handled, in
// its own order, at the now() it saw, and when each timer ran), so every
// node, the timer-driven servo controller included, is driven exactly as it
// ran, and every regenerated channel comes out the same (docs/replay.md
// "Journals"). With --ignore-journals the controller's channels differ
// (its ticks at their due times, not when they ran): the journal is what
// makes them the same.
TEST(Demo, AFreshRecordingReplaysTheSameOrWithEveryDifferenceExplained) {
  ht::TempDir dir;
  std::string out;
  ASSERT_EQ(run_demo({"--set", "config/sets/sim-direct.yaml", "--scenario", "config/scenarios/experiment1.yaml",
                      "--seeds", "7", "--image-rate", "0", "--split-mb", "0"},
                     dir.path(), &out),
            0)
      << out;
  std::vector<fs::path> logs;
  for (const auto& e : fs::directory_iterator(dir / "out"))
    if (e.path().filename().string().rfind("run0-", 0) == 0 && e.path().string().find(".lcm") != std::string::npos)
      logs.push_back(e.path());
  ASSERT_EQ(logs.size(), 1u) << out;
  ht::ChildProcess replay({ht::bin("harvest-replay"), logs.front().string()}, dir / "replay.txt");
  const int code = replay.wait(std::chrono::seconds(120));
  const std::string report = replay.output();
  std::printf("%s\n", report.c_str());
  EXPECT_NE(report.find("nodes from the log's CONFIG snapshots: "), std::string::npos) << report;
  EXPECT_NE(report.find("servo-controller replayed from its journal"), std::string::npos) << report;
  for (const char* channel : {"FRUIT_FIXED", "FRUIT_HAND", "TARGETS", "ROBOT_COMMAND", "HARVEST_STATUS"}) {
    EXPECT_TRUE(report.find(std::string("SAME ") + channel) != std::string::npos ||
                report.find(std::string("EXPLAINED ") + channel) != std::string::npos)
        << channel << "\n"
        << report;
  }
  EXPECT_EQ(code, 0) << report;

  ht::ChildProcess approximate({ht::bin("harvest-replay"), logs.front().string(), "--ignore-journals"},
                               dir / "approximate.txt");
  approximate.wait(std::chrono::seconds(120));
  const std::string without = approximate.output();
  EXPECT_EQ(without.find("replayed from its journal"), std::string::npos) << without;
  // The controller ticks at their due times, not when the live ones ran: its commands or its statuses (a cycle time
  // read off the tick) differ. Which one depends on the live run's jitter (a short run can keep every command).
  EXPECT_TRUE(without.find("DIFF ROBOT_COMMAND") != std::string::npos ||
              without.find("DIFF HARVEST_STATUS") != std::string::npos)
      << "the controller's ticks at their due times\n"
      << without;
}

// The field-faithful set: the simulator plays only the hardware; the robot
// link drives the arm's CiA 402 drives over the virtual CAN bus and the
// end-effector bridge talks to the board over TCP. Two demos at once on this
// machine, each choosing its own LCM port, bus and board port (none given
// here): both pick their fruit, neither hears the other's drives (the robot
// link faults on a frame it did not send) nor takes the other's board port.
TEST(Demo, TwoFieldSetDemosAtOnceEachPickOverTheirOwnCanBusAndBoardPort) {
  ht::TempDir dir;
  std::vector<std::unique_ptr<ht::ChildProcess>> demos;
  for (const std::string k : {"a", "b"}) {
    fs::create_directories(dir / k);
    demos.push_back(std::make_unique<ht::ChildProcess>(
        std::vector<std::string>{ht::bin("harvest-demo"), "--no-plots", "--out", (dir / k / "out").string(), "--set",
                                 "config/sets/sim.yaml", "--scenario", "config/scenarios/experiment1.yaml"},
        dir / k / "demo.txt"));
  }
  std::set<std::string> buses, ports, urls;
  for (std::size_t i = 0; i < demos.size(); ++i) {
    const fs::path d = dir / (i == 0 ? "a" : "b");
    const int code = demos[i]->wait(std::chrono::seconds(240));
    const std::string out = demos[i]->output();
    EXPECT_EQ(code, 0) << out;
    const std::string summary = slurp(d / "out" / "summary.json");
    EXPECT_EQ(rt::Json::parse(summary)["picked"], 1) << summary << out;
    // ROBOT_STATE came from the robot link, IR_RANGE from the bridge.
    const std::string launch_log = slurp(d / "out" / "run0-launch.log");
    EXPECT_NE(launch_log.find("started robot-link"), std::string::npos) << launch_log;
    EXPECT_NE(launch_log.find("started ee-bridge"), std::string::npos) << launch_log;
    // On the run's own bus and port, which the simulator, the link and the bridge were all given.
    std::smatch m;
    ASSERT_TRUE(std::regex_search(out, m, std::regex("virtual CAN bus (udp_multicast:\\S+), board port (\\d+)")))
        << out;
    const std::string bus = m[1], port = m[2];
    EXPECT_NE(bus, "udp_multicast:239.74.163.2:43113?ttl=0");
    EXPECT_NE(port, "4001");
    EXPECT_NE(launch_log.find("devices.bus=" + bus), std::string::npos) << launch_log;
    EXPECT_NE(launch_log.find("robot_link.yaml --set bus=" + bus), std::string::npos) << launch_log;
    EXPECT_NE(launch_log.find("devices.board.port=" + port), std::string::npos) << launch_log;
    EXPECT_NE(launch_log.find("link.tcp.port=" + port), std::string::npos) << launch_log;
    ASSERT_TRUE(std::regex_search(launch_log, m, std::regex("--lcm-url (udpm://\\S+)"))) << launch_log;
    buses.insert(bus);
    ports.insert(port);
    urls.insert(m[1]);
  }
  EXPECT_EQ(buses.size(), 2u);
  EXPECT_EQ(ports.size(), 2u);
  EXPECT_EQ(urls.size(), 2u);
}

TEST(Demo, BadScenarioIsRefusedNamingTheFile) {
  ht::TempDir dir;
  std::string out;
  EXPECT_EQ(run_demo({"--scenario", (dir.path() / "nope.yaml").string()}, dir.path(), &out), 2);
  EXPECT_NE(out.find("nope.yaml"), std::string::npos) << out;
  std::ofstream(dir.path() / "typo.yaml") << "name: t\nfruitt: []\n";
  EXPECT_EQ(run_demo({"--scenario", (dir.path() / "typo.yaml").string()}, dir.path(), &out), 2);
  EXPECT_NE(out.find("fruitt"), std::string::npos) << out;
  // --scenario-set: the overridden scenario is checked like a file (a value out of its choices, no '=').
  EXPECT_EQ(run_demo({"--scenario-set", "look.style=photo"}, dir.path(), &out), 2);
  EXPECT_NE(out.find("look.style"), std::string::npos) << out;
  EXPECT_EQ(run_demo({"--scenario-set", "look.style"}, dir.path(), &out), 2);
  EXPECT_NE(out.find("--scenario-set"), std::string::npos) << out;
}

TEST(Demo, SetRewriteKeepsTheSetAndTellsTheSimulatorItsRun) {
  harvest::demo::SetRewrite rw;
  rw.set_file = ht::source_path("config/sets/sim-direct.yaml");
  rw.extra_args["sim"] = {"--set", "run=3"};
  const std::string text = harvest::demo::rewrite_set(rw);
  EXPECT_NE(text.find("run=3"), std::string::npos) << text;
  EXPECT_NE(text.find("harvest-servo-controller"), std::string::npos) << text;
  EXPECT_NE(text.find("cwd: " + fs::canonical(ht::source_path(".")).string()), std::string::npos) << text;
  // The copy lives elsewhere: the site file is named absolutely.
  rw.set_file = ht::source_path("config/sets/sim.yaml");
  EXPECT_NE(
      harvest::demo::rewrite_set(rw).find("site: " + fs::canonical(ht::source_path("config/site/sim.yaml")).string()),
      std::string::npos);
  rw.extra_args["nosuch"] = {"--set", "a=1"};
  EXPECT_THROW(harvest::demo::rewrite_set(rw), std::runtime_error);
}

}  // namespace
