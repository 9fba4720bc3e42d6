// The simulator node on the replay runner's clock: when it ends a run.
#include "sim/sim_node.hpp"

#include <gtest/gtest.h>

#include "harvest/harvest_status_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "test_scenes.hpp"
#include "test_support.hpp"

namespace harvest::sim {
namespace {

constexpr rt::Micros kT0 = 1'700'000'000'000'000;

// No counted fruit (the only one is beyond the arm's reach): every counted
// fruit is decided from the start.
Scenario nothing_to_pick() {
  Scenario s = test::one_fruit(Vec3(0.0, 2.0, 0.0));
  s.time_limit_s = 30.0;
  return s;
}

// Replays HARVEST_STATUS messages with the given states at the given times
// through a simulator; returns the log time of its last SIM_TRUTH [s after kT0].
double last_truth_s(const std::vector<std::pair<double, std::string>>& statuses) {
  harvest::testing::TempDir dir;
  std::vector<rt::LogRecord> in;
  // A first event at the start, so the node attaches at kT0.
  in.push_back({kT0, "UNRELATED", std::vector<uint8_t>{0}});
  for (const auto& [s, state] : statuses) {
    harvest_status_t st{};
    st.header.utime = kT0 + rt::from_seconds(s);
    st.state = state;
    st.current_fruit_id = -1;
    in.push_back({st.header.utime, channels::kHarvestStatus, rt::encode(st)});
  }
  rt::write_log(dir / "in.lcm", in);
  rt::ReplayOptions o;
  o.input_log = dir / "in.lcm";
  o.output_log = dir / "out.lcm";
  o.tail = rt::from_seconds(40.0);
  SimConfig config;
  config.done_grace_s = 2.0;
  config.render_thread = false;  // logical time: frames rendered on the loop
  SimNode node(config, nothing_to_pick());
  rt::ReplayRunner runner(o);
  runner.add(node);
  runner.run();
  double last = -1.0;
  for (const auto& r : rt::read_log(dir / "out.lcm"))
    if (r.channel == kSimTruthChannel) last = rt::to_seconds(r.timestamp - kT0);
  return last;
}

// Direct mode reports the camera pose as the robot link would: with the
// software's hand-eye file (default config/cameras/hand_eye.yaml), which must
// be readable.
TEST(SimConfig, ReadsTheSoftwaresHandEyeForTheReportedCameraPose) {
  auto doc = config::Document::load_string("scenario: config/scenarios/experiment1.yaml\n");
  const SimConfig c = SimConfig::from_config(doc.root());
  EXPECT_NEAR(c.reported_hand_eye.position.z(), -0.040, 1e-12);
  auto bad =
      config::Document::load_string("scenario: config/scenarios/experiment1.yaml\nhand_eye: /nonexistent/he.yaml\n");
  try {
    SimConfig::from_config(bad.root());
    ADD_FAILURE() << "a missing hand-eye file was accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/he.yaml"), std::string::npos) << e.what();
  }
}

TEST(SimNode, WithNoControllerTheRunEndsOnceEveryCountedFruitIsDecidedAndTheGracePassed) {
  const double end = last_truth_s({});
  EXPECT_GE(end, 2.0);
  EXPECT_LT(end, 2.2);
}

// A controller still at work (here on a fruit that is not counted) is let
// finish: ending the world drops the arm's drives and the gripper board under
// it, and every process on them faults. Once it rests the run ends.
TEST(SimNode, NeverEndsTheRunUnderAControllerAtWork) {
  std::vector<std::pair<double, std::string>> statuses;
  for (int i = 0; i <= 16; ++i) statuses.emplace_back(0.5 * i, "IR_APPROACH");  // at work for 8 s
  statuses.emplace_back(8.2, "DONE");
  const double end = last_truth_s(statuses);
  EXPECT_GE(end, 8.2);
  EXPECT_LT(end, 8.4);
}

// ... unless it falls silent (a controller that died is not waited for).
TEST(SimNode, ASilentControllerIsNotWaitedFor) {
  const double end = last_truth_s({{0.5, "APPROACH"}, {1.0, "APPROACH"}});
  EXPECT_GE(end, 6.0);  // 5 s after it was last heard
  EXPECT_LT(end, 6.2);
}

// On logical time every step runs at its due time: nothing is late, and
// every frame is rendered (on the loop).
TEST(SimNode, KeepsPerfectTimeOnLogicalTime) {
  harvest::testing::TempDir dir;
  rt::write_log(dir / "in.lcm", {{kT0, "UNRELATED", std::vector<uint8_t>{0}}});
  rt::ReplayOptions o;
  o.input_log = dir / "in.lcm";
  o.output_log = dir / "out.lcm";
  o.tail = rt::from_seconds(3.0);
  SimConfig config;
  config.render_thread = false;
  config.stop_when_done = false;
  SimNode node(config, nothing_to_pick());
  rt::ReplayRunner runner(o);
  runner.add(node);
  runner.run();
  const auto& steps = node.timekeeping().steps();
  ASSERT_EQ(steps.size(), 3u);  // robot_state, ir, physics
  for (const auto& s : steps) {
    EXPECT_GE(s.steps, 59) << s.name;  // 3 s at 20..100 Hz
    EXPECT_EQ(s.late, 0) << s.name;
    EXPECT_EQ(s.max_late, 0) << s.name;
  }
  EXPECT_EQ(node.timekeeping().frames(CameraId::kFixed).dropped, 0);
  EXPECT_GE(node.timekeeping().frames(CameraId::kFixed).rendered, 89);  // 30 Hz
}

}  // namespace
}  // namespace harvest::sim
