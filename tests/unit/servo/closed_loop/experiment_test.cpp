// Closed-loop tests (closed_loop/loop.hpp): Experiment I of the thesis and whole runs: convergence over calibration
// errors, every fruit picked, the limits and the workspace respected, a recorded run replayed byte for byte.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "closed_loop/loop.hpp"
#include "runtime/replay_runner.hpp"
#include "servo/geometry.hpp"
#include "test_support.hpp"

namespace harvest::servo::testing {
namespace {

// Experiment I: every run (different pixel noise, calibration errors) ends
// with the fruit inside the gripper and picked.
TEST(ClosedLoop, ExperimentOneConvergesEveryTime) {
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    WorldSpec spec = experiment_one();
    spec.seed = seed;
    if (seed <= 5) {
      spec.hand_depth_scale = 0.92 + 0.04 * seed;  // depth over- and underestimated
      spec.true_hand.cx += 3.0 * (static_cast<double>(seed) - 3.0);
    } else {
      // Random calibration errors on top of table 6-4's: fixed-camera
      // extrinsic +-5 cm per axis, hand focal lengths +-5 %, principal point
      // +-10 px, depth scale 0.9..1.1.
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      spec.fixed_error += 0.05 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      spec.true_hand.fx *= 1.0 + 0.05 * u(rng);
      spec.true_hand.fy *= 1.0 + 0.05 * u(rng);
      spec.true_hand.cx += 10.0 * u(rng);
      spec.true_hand.cy += 10.0 * u(rng);
      spec.hand_depth_scale = 1.0 + 0.1 * u(rng);
    }
    Loop loop(spec);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    const fruit_outcome_t* o = loop.outcome(1);
    ASSERT_NE(o, nullptr);
    EXPECT_EQ(o->outcome, +fruit_outcome_t::PICKED) << o->detail;
    EXPECT_TRUE(loop.world.fruit_picked(1));
    ASSERT_TRUE(loop.world.close_position().has_value());
    const double miss = (*loop.world.close_position() - spec.fruits[0].position).norm();
    EXPECT_LT(miss, 0.02) << "tool point " << miss * 1000 << " mm from the fruit centre when closing";
    EXPECT_GT(o->cycle_time_s, 1.0);
    EXPECT_LT(o->cycle_time_s, 40.0);
    const double fastest = expect_within_limits(loop);
    std::printf("seed %u: closed %.1f mm from the fruit centre, cycle %.2f s, fastest command %.4f m/s\n", seed,
                miss * 1000, o->cycle_time_s, fastest);
    // The last command leaves the arm still.
    loop.at(loop.t() + 0.1);
    EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  }
}

TEST(ClosedLoop, PicksEveryFruitThenStops) {
  WorldSpec spec = experiment_one();
  spec.fixed_error = Eigen::Vector3d(0.01, -0.02, 0.03);
  spec.fruits = {{1, {-0.2667, 1.0160, -0.5402}, 0.075},   // experiment II fruit 1
                 {2, {-0.0686, 1.1684, -0.3751}, 0.075},   // experiment II fruit 2
                 {3, {-0.4126, 1.0114, -0.5289}, 0.075}};  // experiment III fruit 3
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 120.0)) << loop.ctrl.machine().summary();
  for (int id = 1; id <= 3; ++id) {
    ASSERT_NE(loop.outcome(id), nullptr) << id;
    EXPECT_EQ(loop.outcome(id)->outcome, +fruit_outcome_t::PICKED) << id << ": " << loop.outcome(id)->detail;
  }
  const auto status = loop.bus.messages<harvest_status_t>(ch::kHarvestStatus).back().second;
  EXPECT_EQ(status.picked, 3);
  EXPECT_EQ(status.remaining, 0);
  EXPECT_EQ(status.num_outcomes, 3);
  EXPECT_EQ(status.state, "DONE");
  expect_within_limits(loop);
}

// A motion that would leave the workspace is clipped at its boundary: with
// the IR sensor dead the IR-guided approach pushes on along the tool axis,
// toward a face placed 3 cm behind the fruit.
TEST(ClosedLoop, WorkspaceBoundsAreNeverCrossed) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  ServoConfig cfg = test_config();
  cfg.workspace.max.y() = spec.fruits[0].position.y() + 0.03;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  EXPECT_GT(loop.ctrl.machine().workspace_clips(), 0) << "the test never reached the boundary";
  double closest = 1e9;  // closest approach of the tool to the face
  Eigen::Vector3d tool = Eigen::Vector3d::Zero();
  for (const auto& r : loop.bus.log()) {
    if (r.channel == ch::kRobotState) {
      tool = to_isometry(rt::decode<robot_state_t>(r.data)->tool_pose).translation();
      EXPECT_TRUE(cfg.workspace.contains(tool, -1e-9)) << "tool at y " << tool.y();
      closest = std::min(closest, cfg.workspace.max.y() - tool.y());
    } else if (r.channel == ch::kRobotCommand) {
      // Executed for its whole validity window, a twist still ends inside.
      const auto c = *rt::decode<robot_command_t>(r.data);
      if (c.type == robot_command_t::TYPE_TWIST) {
        EXPECT_TRUE(cfg.workspace.contains(tool + linear(c) * cfg.validity_s, -1e-9));
      }
      if (c.type == robot_command_t::TYPE_POSE_GOAL) {
        EXPECT_TRUE(cfg.workspace.contains(to_isometry(c.pose_goal).translation()));
      }
    }
  }
  EXPECT_LT(closest, 0.01) << "the approach should have been pressed against the face";
  EXPECT_EQ(published_outcomes(loop, 1).at(0).outcome, +fruit_outcome_t::FAILED_GRASP);
  expect_motion_stopped(loop);
}

// approach_mode selects the strategy; tbz makes the node listen to FEATURE_MATCHES.
TEST(ServoConfig, ApproachModeSelectsTheStrategyAndItsInputs) {
  for (const std::string mode : {"reconstruction", "tbz"}) {
    const auto doc = config::Document::load_string("approach_mode: " + mode);
    const ServoConfig cfg = ServoConfig::from_yaml(doc.root());
    rt::SimRunner bus(kT0);
    ServoControllerNode ctrl(cfg, harvest::testing::sim_authority(harvest::testing::kController, ""));
    bus.add(ctrl);
    bus.start();
    EXPECT_EQ(ctrl.machine().approach_name(), mode);
    EXPECT_EQ(bus.is_subscribed(ch::kFeatureMatches), mode == "tbz") << mode;
  }
  const auto bad = config::Document::load_string("approach_mode: bogus");
  EXPECT_THROW(ServoConfig::from_yaml(bad.root()), config::Error);
}

// Record a closed-loop run, replay the controller's inputs through
// rt::ReplayRunner: the regenerated outputs are byte-identical.
TEST(ClosedLoop, ReplayOfARecordedLogGivesIdenticalCommands) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.max_attempts_per_fruit = 2;  // the e-stopped fruit is attempted again
  Loop loop(spec, cfg);
  loop.start();
  loop.at(1.2);  // during the approach
  ASSERT_EQ(loop.ctrl.machine().state(), State::kApproach);
  loop.send(1.2005, ch::kEmergencyStop, estop(true, false));
  loop.send(2.2005, ch::kEmergencyStop, estop(false, true));
  loop.start(2.2015);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.ctrl.machine().outcomes().back().outcome, +fruit_outcome_t::PICKED);
  harvest::testing::TempDir dir;
  rt::write_log((dir / "in.lcmlog").string(), loop.bus.log());

  auto replay_once = [&](const std::string& out) {
    rt::ReplayOptions options;
    options.input_log = (dir / "in.lcmlog").string();
    options.output_log = (dir / out).string();
    rt::ReplayRunner runner(options);
    ServoControllerNode ctrl(cfg, harvest::testing::sim_authority(harvest::testing::kController, ""));
    runner.add(ctrl);
    runner.run();
    return rt::read_log((dir / out).string());
  };
  const auto replayed = replay_once("out1.lcmlog");
  // The replay runs to the last event of the log, firing the controller's
  // timers at log time on the way: it must regenerate everything the
  // controller published, in order, with the same timestamps and bytes.
  const std::set<std::string> outputs{ch::kRobotCommand, ch::kGripperCommand, ch::kHarvestStatus};
  std::vector<rt::LogRecord> recorded;
  for (const auto& r : loop.bus.log())
    if (outputs.count(r.channel)) recorded.push_back(r);
  EXPECT_EQ(rt::first_difference(recorded, replayed), std::nullopt);
  // ... and what it regenerated is the whole story: the e-stop, the restart and the pick.
  int stops = 0, twists = 0, goals = 0, closes = 0, opens = 0;
  for (const auto& r : replayed) {
    if (r.channel == ch::kRobotCommand) {
      const auto c = *rt::decode<robot_command_t>(r.data);
      stops += c.type == robot_command_t::TYPE_STOP;
      twists += c.type == robot_command_t::TYPE_TWIST;
      goals += c.type == robot_command_t::TYPE_POSE_GOAL;
    } else if (r.channel == ch::kGripperCommand) {
      const auto g = *rt::decode<gripper_command_t>(r.data);
      closes += g.action == gripper_command_t::ACTION_CLOSE;
      opens += g.action == gripper_command_t::ACTION_OPEN;
    }
  }
  EXPECT_GT(stops, 40);  // latched e-stop for 1 s at 50 Hz
  EXPECT_GT(twists, 0);
  EXPECT_GT(goals, 0);
  EXPECT_EQ(closes, 1);
  EXPECT_EQ(opens, 1);
  ASSERT_FALSE(replayed.empty());
  const auto last_status = [&] {
    for (auto it = replayed.rbegin(); it != replayed.rend(); ++it)
      if (it->channel == ch::kHarvestStatus) return *rt::decode<harvest_status_t>(it->data);
    return harvest_status_t{};
  }();
  EXPECT_EQ(last_status.picked, 1);
  std::printf("replayed %zu records (%d stop, %d twist, %d pose goal commands)\n", replayed.size(), stops, twists,
              goals);
  EXPECT_EQ(rt::first_difference(replayed, replay_once("out2.lcmlog")), std::nullopt);
  expect_within_limits(loop);
}

}  // namespace
}  // namespace harvest::servo::testing
