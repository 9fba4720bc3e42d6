#include "launch/set_spec.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_support.hpp"

namespace harvest::launch {
namespace {

SetSpec parse(const std::string& yaml, const std::filesystem::path& file = "/sets/test.yaml") {
  const config::Document doc = config::Document::load_string(yaml, file.string());
  return parse_set(doc.root(), file);
}

std::string parse_error(const std::string& yaml) {
  try {
    parse(yaml);
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(SetSpec, ReadsEveryField) {
  const SetSpec s = parse(R"(
name: demo
bin_dir: ../bin
lcm_url: udpm://239.255.76.67:7667?ttl=1
prefix: ARM2_
processes:
  - name: link
    command: harvest-robot-link
    args: [--config, config/arm/k1207i.yaml]
    env: {FOO: bar}
    cwd: /tmp
    group: robot
    critical: true
    stop_first: true
    ends_set: true
    heartbeat_timeout_s: 2
    stop_timeout_s: 4
    restart: {policy: always, max_restarts: -1, backoff_s: 0.2, backoff_factor: 3, backoff_max_s: 5}
  - name: servo
    command: harvest-servo-controller
    after: link
recording: {enabled: true, folder: /data, channels: "CAMERA_.*", invert_channels: true, split_mb: 100}
)");
  EXPECT_EQ(s.name, "demo");
  EXPECT_EQ(s.bin_dir, "/bin");
  EXPECT_EQ(s.prefix, "ARM2_");
  ASSERT_EQ(s.processes.size(), 2u);
  const ProcessSpec& l = s.processes[0];
  EXPECT_EQ(l.args, (std::vector<std::string>{"--config", "config/arm/k1207i.yaml"}));
  EXPECT_EQ(l.env.at("FOO"), "bar");
  EXPECT_EQ(l.cwd, "/tmp");
  EXPECT_EQ(l.group, "robot");
  EXPECT_TRUE(l.critical);
  EXPECT_TRUE(l.stop_first);
  EXPECT_TRUE(l.ends_set);
  EXPECT_DOUBLE_EQ(l.heartbeat_timeout_s, 2);
  EXPECT_EQ(l.restart.mode, RestartMode::kAlways);
  EXPECT_EQ(l.restart.max_restarts, -1);
  EXPECT_DOUBLE_EQ(l.restart.backoff_factor, 3);
  const ProcessSpec& sv = s.processes[1];
  EXPECT_EQ(sv.after, std::vector<std::string>{"link"});
  EXPECT_EQ(sv.cwd, "/");  // default: the repository root, two folders above the set
  EXPECT_DOUBLE_EQ(sv.heartbeat_timeout_s, 3);  // harvest processes are expected to beat
  EXPECT_FALSE(sv.critical);
  EXPECT_FALSE(sv.ends_set);
  EXPECT_TRUE(s.recording.enabled);
  EXPECT_EQ(s.recording.folder, "/data");
  EXPECT_TRUE(s.recording.invert_channels);
}

TEST(SetSpec, RefusesInvalidSetsWithClearMessages) {
  EXPECT_NE(parse_error("processes: []").find("processes: expected a non-empty list"), std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a}]").find("processes[0].command: expected a required value"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, restrat: {}}]").find("processes[0].restrat: unknown key"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x}, {name: a, command: y}]").find("used twice"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, after: [b]}]").find("unknown process 'b'"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, after: [b]}, {name: b, command: y, after: [a]}]")
                .find("dependency cycle: a -> b -> a"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, restart: {policy: sometimes}}]")
                .find("one of {never, on-failure, always}"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, stop_timeout_s: -1}]").find("stop_timeout_s"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: a, command: x, args: {a: 1}}]").find("args: expected a list of strings"),
            std::string::npos);
  EXPECT_NE(parse_error("processes: [{name: 'a b', command: x}]").find("without spaces"), std::string::npos);
}

TEST(SetSpec, StartOrderFollowsDependenciesThenDeclarationOrder) {
  const SetSpec s = parse(R"(
processes:
  - {name: servo, command: x, after: [link, reconstructor]}
  - {name: camera, command: x}
  - {name: reconstructor, command: x, after: [camera]}
  - {name: link, command: x, group: robot}
)");
  std::vector<std::string> names;
  for (std::size_t i : start_order(s)) names.push_back(s.processes[i].name);
  EXPECT_EQ(names, (std::vector<std::string>{"link", "camera", "reconstructor", "servo"}));
  const auto robot = select_group(s, "robot");
  ASSERT_EQ(robot.size(), 1u);
  EXPECT_EQ(s.processes[robot[0]].name, "link");
  EXPECT_EQ(select_group(s, "").size(), 4u);
  // Several groups on one host (a deputy running the simulator and the robot).
  EXPECT_EQ(select_group(s, "robot,default").size(), 4u);
  EXPECT_EQ(select_group(s, ",robot,nope,"), robot);
  EXPECT_TRUE(select_group(s, "nope").empty());
}

TEST(SetSpec, RestartDelayBacksOffAndGivesUp) {
  RestartPolicy p;
  p.mode = RestartMode::kOnFailure;
  p.max_restarts = 4;
  p.backoff_initial_s = 0.5;
  p.backoff_factor = 2;
  p.backoff_max_s = 3;
  EXPECT_DOUBLE_EQ(*restart_delay(p, 0, true), 0.5);
  EXPECT_DOUBLE_EQ(*restart_delay(p, 1, true), 1.0);
  EXPECT_DOUBLE_EQ(*restart_delay(p, 2, true), 2.0);
  EXPECT_DOUBLE_EQ(*restart_delay(p, 3, true), 3.0);  // capped
  EXPECT_FALSE(restart_delay(p, 4, true));            // gave up
  EXPECT_FALSE(restart_delay(p, 0, false));           // clean exit is not restarted on-failure
  p.mode = RestartMode::kAlways;
  EXPECT_TRUE(restart_delay(p, 0, false));
  p.max_restarts = -1;
  EXPECT_TRUE(restart_delay(p, 1000, true));
  p.mode = RestartMode::kNever;
  EXPECT_FALSE(restart_delay(p, 0, true));
}

TEST(SetSpec, CommandLinesAndPreflight) {
  testing::TempDir dir;
  const auto exe = dir / "harvest-thing";
  std::ofstream(exe) << "#!/bin/sh\n";
  std::filesystem::permissions(exe, std::filesystem::perms::owner_all);
  std::ofstream(dir / "set.yaml") << "bin_dir: .\nlcm_url: udpm://239.255.76.67:7667?ttl=1\nprefix: P_\n"
                                     "processes:\n  - {name: t, command: harvest-thing, args: [-v], cwd: .}\n"
                                     "  - {name: m, command: harvest-missing, cwd: .}\n"
                                     "  - {name: s, command: harvest-thing, harvest_options: false, cwd: nowhere}\n";
  const SetSpec s = load_set(dir / "set.yaml");
  EXPECT_EQ(command_line(s, s.processes[0]),
            (std::vector<std::string>{exe.string(), "-v", "--instance", "t", "--prefix", "P_", "--lcm-url",
                                      "udpm://239.255.76.67:7667?ttl=1"}));
  EXPECT_EQ(command_line(s, s.processes[2]), std::vector<std::string>{exe.string()});
  const auto problems = preflight(s, {0, 1, 2});
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_NE(problems[0].find("m: executable 'harvest-missing' not found"), std::string::npos);
  EXPECT_NE(problems[1].find("s: working directory"), std::string::npos);
  EXPECT_TRUE(preflight(s, {0}).empty());
}

TEST(SetSpec, RecorderCommandLine) {
  // harvest-record by default: lcm-logger's options plus the reduced image rate and the reports.
  const std::string rec =
      "processes: [{name: a, command: x}]\nrecording: {enabled: true, folder: /logs, "
      "channels: 'TRUTH_.*', invert_channels: true, split_mb: 50, file_prefix: run, "
      "image_rate_hz: 5, status_s: 2, warn_free_mb: 300";
  const SetSpec s = parse(rec + "}");
  EXPECT_TRUE(is_harvest_record(s.recording));
  auto argv = recorder_command_line(s, "20260101-000000");
  std::vector<std::string> tail(argv.begin() + 1, argv.end());
  EXPECT_EQ(tail, (std::vector<std::string>{"--channel=TRUTH_.*", "--invert-channels", "-i", "--split-mb=50.000000",
                                            "--max-rate=CAMERA_.*=5.000000", "--status-s=2.000000",
                                            "--warn-free-mb=300.000000", "--warn-fill-minutes=10.000000",
                                            "/logs/run-20260101-000000.lcm"}));
  EXPECT_TRUE(preflight(s, {}).empty() || preflight(s, {})[0].find("image_rate_hz") == std::string::npos);

  // The stock lcm-logger: its own options only; a reduced image rate it cannot do is refused before the start.
  const SetSpec stock = parse(rec + ", logger: lcm-logger}");
  EXPECT_FALSE(is_harvest_record(stock.recording));
  argv = recorder_command_line(stock, "20260101-000000");
  tail.assign(argv.begin() + 1, argv.end());
  EXPECT_EQ(tail, (std::vector<std::string>{"--quiet", "--channel=TRUTH_.*", "--invert-channels", "-i",
                                            "--split-mb=50.000000", "/logs/run-20260101-000000.lcm"}));
  const auto problems = preflight(stock, {});
  ASSERT_FALSE(problems.empty());
  EXPECT_EQ(problems.back(),
            "recording: image_rate_hz needs logger harvest-record ('lcm-logger' records every message)");
}

// Every shipped set must stay valid (executables are checked at launch, not here).
TEST(SetSpec, ShippedSetsParse) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(testing::source_path("config/sets"))) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_NO_THROW(load_set(e.path()));
    ++n;
  }
  EXPECT_GE(n, 3);
}

}  // namespace
}  // namespace harvest::launch
