// The thesis experiments II and III and a short tree in CI (issue 21 item 6):
// each through harvest-demo headless with the sim-direct set, judged by its
// own success criterion from the summary, not only by the exit code.
//
// Thesis section 6.4: a run succeeds when the target fruit is inside the
// gripper at the end of the control loop; here that is the simulator's
// "picked" (held within its capture envelope and pulled off its stem). Its
// final gripper-to-fruit error must also stay within kMaxFinalErrorMm: with
// this set the controller closes 6-10 mm from the centre (docs/demo.md), and
// 18.5 mm without the grasp advance; the gripper holds a fruit up to 22 mm
// (capture_radius_mm) off its axis. 15 mm fails on a lost grasp advance or a
// like regression of the aim before fruit start to drop.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <optional>

#include "demo_support.hpp"
#include "harvest/robot_state_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/json.hpp"
#include "runtime/log_io.hpp"

namespace ht = harvest::testing;
namespace fs = std::filesystem;
namespace rt = harvest::rt;

namespace {

using ht::run_demo;
using ht::slurp;

constexpr double kMaxFinalErrorMm = 15.0;

Eigen::Vector3d mm(const rt::Json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }

// The summary's fruit of run `run` whose true position is within 5 mm of `at_mm`, null if none.
const rt::Json* fruit_at(const rt::Json& summary, int run, const Eigen::Vector3d& at_mm) {
  for (const auto& f : summary["fruit"])
    if (f["run"] == run && (mm(f["true_position_mm"]) - at_mm).norm() < 5.0) return &f;
  return nullptr;
}

// Where the tool was when run `run` began: its first ROBOT_STATE in the run's recording [mm].
std::optional<Eigen::Vector3d> start_tool_mm(const fs::path& out_dir, int run) {
  const std::string prefix = "run" + std::to_string(run) + "-";
  std::vector<fs::path> parts;
  for (const auto& e : fs::directory_iterator(out_dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && name.find(".lcm") != std::string::npos) parts.push_back(e.path());
  }
  std::sort(parts.begin(), parts.end());
  for (const auto& p : parts)
    for (const auto& r : rt::read_log(p.string()))
      if (r.channel == harvest::channels::kRobotState)
        if (const auto s = rt::decode<harvest::robot_state_t>(r.data))
          return Eigen::Vector3d(s->tool_pose.position[0], s->tool_pose.position[1], s->tool_pose.position[2]) * 1e3;
  return std::nullopt;
}

void expect_started_at(const ht::TempDir& dir, int run, const Eigen::Vector3d& table_mm) {
  const auto start = start_tool_mm(dir / "out", run);
  ASSERT_TRUE(start.has_value()) << "no ROBOT_STATE recorded in run " << run;
  EXPECT_LT((*start - table_mm).norm(), 5.0) << "run " << run << " started at " << start->transpose();
}

// A failed test shows the demo's whole output (the controller's states, fruit and tallies per run).
struct PrintOnFailure {
  const std::string& out;
  ~PrintOnFailure() {
    if (::testing::Test::HasFailure()) std::printf("harvest-demo output:\n%s\n", out.c_str());
  }
};

rt::Json run_scenario(const std::vector<std::string>& args, const ht::TempDir& dir, std::string* out) {
  std::vector<std::string> all = {"--set", "config/sets/sim-direct.yaml", "--image-rate", "2"};
  all.insert(all.end(), args.begin(), args.end());
  const int code = run_demo(all, dir.path(), out, std::chrono::seconds(300));
  EXPECT_EQ(code, 0) << *out;
  // Every run ended with the controller DONE, none in FAULT (the demo exits 1 then, but say it here too).
  EXPECT_EQ(out->find("controller FAULT"), std::string::npos) << *out;
  const std::string text = slurp(dir / "summary.json");
  const auto table = out->rfind(": ended normally");  // the figures follow the last run's line
  std::printf("%s\n", out->substr(table == std::string::npos ? 0 : table).c_str());
  return text.empty() ? rt::Json() : rt::Json::parse(text);
}

// Experiment II (section 6.4.3, tables 6-7, 6-8): two fruit, fruit #1 hidden
// from the fixed camera by a leaf, so only fruit #2 can be chosen; the camera
// in hand sees both once the gripper has turned toward #2. From each of the
// three start poses of table 6-8 fruit #2 is picked and fruit #1 stays on the
// tree (neither chosen nor knocked off by the approach beside it), and the
// final positions agree from start pose to start pose as the thesis's do.
TEST(DemoScenarios, ExperimentTwoPicksTheFruitTheFixedCameraSeesFromEachStartPose) {
  ht::TempDir dir;
  std::string out;
  const PrintOnFailure print{out};
  const rt::Json j = run_scenario({"--scenario", "config/scenarios/experiment2.yaml", "--runs", "3"}, dir, &out);
  ASSERT_EQ(j["per_run"].size(), 3u) << out;
  // Table 6-7's fruit and table 6-8's start poses (run k uses variant k).
  const Eigen::Vector3d fruit1(-266.7, 1016.0, -540.2), fruit2(-68.6, 1168.4, -375.1);
  const Eigen::Vector3d starts[3] = {{549.0, 896.0, -203.0}, {40.0, 979.0, 61.0}, {-715.0, 748.0, 47.0}};
  for (int run = 0; run < 3; ++run) {
    SCOPED_TRACE("run " + std::to_string(run));
    expect_started_at(dir, run, starts[run]);
    const rt::Json* hidden = fruit_at(j, run, fruit1);
    const rt::Json* seen = fruit_at(j, run, fruit2);
    ASSERT_TRUE(hidden && seen) << j.dump(1);
    EXPECT_FALSE((*hidden)["counted"].get<bool>()) << "fruit #1 should be hidden from the fixed camera";
    EXPECT_LT((*hidden)["visible_fraction"].get<double>(), 0.5);
    EXPECT_EQ((*hidden)["outcome"].get<std::string>(), "on tree");
    EXPECT_TRUE((*seen)["counted"].get<bool>());
    EXPECT_EQ((*seen)["outcome"].get<std::string>(), "picked");
    ASSERT_TRUE((*seen)["final_error_mm"].is_number());
    EXPECT_LE((*seen)["final_error_mm"].get<double>(), kMaxFinalErrorMm);
    EXPECT_EQ(j["per_run"][run]["picked"], 1);
    EXPECT_EQ(j["per_run"][run]["picked_any"], 1) << "only fruit #2 is picked";
  }
  // Table 6-8's final positions scatter by up to 9.8 mm (x std over its three
  // rows); ours, the tool at the grasp over the three runs, no more.
  ASSERT_EQ(j["final_position_std_mm"].size(), 3u);
  for (int axis = 0; axis < 3; ++axis) EXPECT_LE(j["final_position_std_mm"][axis].get<double>(), 9.8) << axis;
}

// Experiment III (section 6.4.4, table 6-9): in each run another target
// position with its own start pose; each is picked, within the bound.
TEST(DemoScenarios, ExperimentThreePicksEachTargetFromItsStartPose) {
  ht::TempDir dir;
  std::string out;
  const PrintOnFailure print{out};
  const rt::Json j = run_scenario({"--scenario", "config/scenarios/experiment3.yaml", "--runs", "3"}, dir, &out);
  ASSERT_EQ(j["per_run"].size(), 3u) << out;
  // Table 6-9: targets and start poses (run k uses variant k).
  const Eigen::Vector3d targets[3] = {{-266.7, 1016.0, -540.2}, {-228.6, 1066.8, -540.2}, {-412.6, 1011.4, -528.9}};
  const Eigen::Vector3d starts[3] = {{-138.0, 1015.0, -223.0}, {-538.0, 554.0, -920.0}, {39.0, 981.0, 69.0}};
  for (int run = 0; run < 3; ++run) {
    SCOPED_TRACE("run " + std::to_string(run));
    expect_started_at(dir, run, starts[run]);
    const rt::Json* f = fruit_at(j, run, targets[run]);
    ASSERT_NE(f, nullptr) << j.dump(1);
    EXPECT_TRUE((*f)["counted"].get<bool>());
    EXPECT_EQ((*f)["outcome"].get<std::string>(), "picked");
    ASSERT_TRUE((*f)["final_error_mm"].is_number());
    EXPECT_LE((*f)["final_error_mm"].get<double>(), kMaxFinalErrorMm);
    EXPECT_EQ(j["per_run"][run]["reachable"], 1);
    EXPECT_EQ(j["per_run"][run]["picked"], 1);
  }
  EXPECT_EQ(j["picked"], 3);
  EXPECT_LE(j["max_final_error_mm"].get<double>(), kMaxFinalErrorMm);
}

// A short tree (config/scenarios/tree_short.yaml: tree.yaml's generator with
// 4 fruit and 100 leaves, its own seed): every counted fruit is picked, none
// is knocked off (the simulator's only collision: a fruit hit by the fingers
// or the palm falls), the aim within the bound on average. Seeds 404 and 1-4
// by hand: 19 of 19 counted picked, final error at most 10.2 mm (docs/demo.md).
TEST(DemoScenarios, ShortTreeIsPickedCleanly) {
  ht::TempDir dir;
  std::string out;
  const PrintOnFailure print{out};
  const rt::Json j = run_scenario({"--scenario", "config/scenarios/tree_short.yaml"}, dir, &out);
  ASSERT_EQ(j["per_run"].size(), 1u) << out;
  EXPECT_GE(j["reachable"].get<int>(), 3) << "the short tree should still have several counted fruit";
  EXPECT_EQ(j["picked"], j["reachable"]);
  for (const auto& f : j["fruit"]) {
    EXPECT_NE(f["outcome"].get<std::string>(), "knocked off") << f.dump();
    if (f["counted"].get<bool>()) {
      EXPECT_EQ(f["outcome"].get<std::string>(), "picked") << f.dump();
    }
  }
  EXPECT_LE(j["mean_final_error_mm"].get<double>(), kMaxFinalErrorMm);
  // The harvest states went by: the camera in hand took over, IR closed the gap.
  EXPECT_NE(out.find("IR_APPROACH"), std::string::npos) << out;
}

// Experiment I with both detectors in learned mode (the network,
// config/vision/models/fruit_net.onnx) on the realistic render (`look.style:
// field`): the learned detector closes the loop. By hand on the field set
// (2026-12-04, docs/perception.md "The closed loop on the learned detector"):
// picked in 4.5-4.6 s, final error about 11 mm.
TEST(DemoScenarios, ExperimentOneIsPickedWithTheLearnedDetectorsOnTheFieldLook) {
  ht::TempDir dir;
  std::string out;
  const PrintOnFailure print{out};
  const rt::Json j = run_scenario(
      {"--scenario", "config/scenarios/experiment1.yaml", "--scenario-set", "look.style=field", "--process-set",
       "detector-fixed:detector.mode=learned", "--process-set", "detector-hand:detector.mode=learned"},
      dir, &out);
  // What ran: the simulator read the overridden scenario, the detectors their mode.
  const std::string scenario = slurp(dir / "out" / "scenario.yaml"), set = slurp(dir / "out" / "run0-set.yaml");
  EXPECT_NE(scenario.find("style: field"), std::string::npos) << scenario;
  EXPECT_NE(set.find((dir / "out" / "scenario.yaml").string()), std::string::npos) << set;
  EXPECT_NE(set.find("config/vision/detector-fixed.yaml, --set, detector.mode=learned"), std::string::npos) << set;
  EXPECT_NE(set.find("config/vision/detector-hand.yaml, --set, detector.mode=learned"), std::string::npos) << set;
  ASSERT_EQ(j["per_run"].size(), 1u) << out;
  EXPECT_EQ(j["reachable"], 1);
  EXPECT_EQ(j["picked"], 1);
  ASSERT_TRUE(j["max_final_error_mm"].is_number()) << j.dump(1);
  EXPECT_LE(j["max_final_error_mm"].get<double>(), kMaxFinalErrorMm);
  EXPECT_NE(out.find("IR_APPROACH"), std::string::npos) << out;
}
}  // namespace
