// harvest-calibrate plan: the planned poses (a unit of lib/calib/pose_plan)
// and the runner that moves the arm through them (lib/calib/plan_runner),
// against a stand-in robot link that checks every command's signature as the
// real one does, on logical time.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <fmt/format.h>
#include <set>

#include "arm/robot_link_config.hpp"
#include "calib/calibration_node.hpp"
#include "calib/link_reach.hpp"
#include "calib/plan_runner.hpp"
#include "calib/pose_plan.hpp"
#include "calib/solvers.hpp"
#include "calib_scenes.hpp"
#include "geometry/pose_msg.hpp"
#include "harvest/robot_command_t.hpp"
#include "kinematics/chain.hpp"
#include "runtime/channels.hpp"
#include "runtime/sim_runner.hpp"
#include "security/authority.hpp"
#include "security/key.hpp"
#include "sim/cameras.hpp"
#include "sim/devices.hpp"

namespace harvest::calib {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;

Isometry3d pose(double x, double y, double z, double rx_deg = 0, double ry_deg = 0, double rz_deg = 0) {
  Isometry3d t = Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(rx_deg * M_PI / 180, Vector3d::UnitX()) *
                Eigen::AngleAxisd(ry_deg * M_PI / 180, Vector3d::UnitY()) *
                Eigen::AngleAxisd(rz_deg * M_PI / 180, Vector3d::UnitZ()))
                   .toRotationMatrix();
  t.translation() = Vector3d(x, y, z);
  return t;
}

// ---- the plans ----

TEST(PosePlan, HandEyeCameraLooksAtTheBoardCentreFromAroundItsNormal) {
  const BoardSpec board;  // 7 x 5 squares of 40 mm: centre (0.14, 0.10, 0) in the board frame
  const Isometry3d board_in_base = pose(-0.38, 0.8, -0.3, -90, 0, 0);
  const Isometry3d camera_in_tool = pose(0.014, -0.009, -0.048, 0.6, -0.8, 1.5);
  const HandEyePlan plan;
  const auto tools = plan_hand_eye(board_in_base, board, camera_in_tool, plan);
  ASSERT_EQ(tools.size(), 12u);
  const Vector3d centre = board_in_base * Vector3d(0.14, 0.10, 0.0);
  const Vector3d normal = board_in_base.linear() * Vector3d(0, 0, -1);  // out of the print, towards the camera
  for (std::size_t k = 0; k < tools.size(); ++k) {
    const Isometry3d camera = tools[k] * camera_in_tool;
    const Vector3d to_centre = centre - camera.translation();
    // At the planned distance (the board centre 30 mm off the axis at most).
    const double depth = plan.distance_m + plan.depth_step_m * static_cast<double>(k % 5);
    EXPECT_NEAR((camera.inverse() * centre).z(), depth, 1e-9) << k;
    // Looking at the centre to within the planned offset, from the printed side, tilted as planned.
    const double off_axis = std::acos(to_centre.normalized().dot(camera.linear().col(2)));
    EXPECT_LE(off_axis, std::atan2(plan.offset_m, depth) + 1e-9) << k;
    EXPECT_GT(camera.linear().col(2).dot(-normal), std::cos((plan.tilt_deg * std::sqrt(2) + 5) * M_PI / 180)) << k;
  }
  // Rotations about several axes: what the solver needs (it refuses one axis).
  EXPECT_NO_THROW(check_rotation_diversity(tools, PoseOptions{}));
}

TEST(PosePlan, ExtrinsicsShowTheCarriedBoardAcrossTheImageOfAnImproperCamera) {
  const BoardSpec board;
  // The thesis's fixed camera: an improper frame (determinant -1).
  Isometry3d camera = Isometry3d::Identity();
  camera.linear() << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  camera.translation() = Vector3d(-0.24, 0.23, -0.40);
  ASSERT_LT(camera.linear().determinant(), 0);
  const Isometry3d board_in_tool = pose(0.10, -0.14, 0.06, 180, 0, 90);
  const auto tools = plan_extrinsics(camera, board, board_in_tool);
  ASSERT_EQ(tools.size(), 9u);
  std::set<std::pair<int, int>> cells;
  for (const auto& tool : tools) {
    // The board centre in the camera's proper twin: in front, across a 3 x 3 grid.
    const Vector3d c = proper_twin(camera).inverse() * (tool * board_in_tool * Vector3d(0.14, 0.10, 0.0));
    EXPECT_GE(c.z(), 0.6 - 1e-9);
    EXPECT_LE(c.z(), 0.7 + 1e-9);
    cells.insert({static_cast<int>(std::lround(c.x() / c.z() / 0.1 * 0.6)),
                  static_cast<int>(std::lround(c.y() / c.z() / 0.08 * 0.6))});
    EXPECT_NEAR(tool.linear().determinant(), 1.0, 1e-9);  // a tool pose is always proper
  }
  EXPECT_EQ(cells.size(), 9u);
  EXPECT_NO_THROW(check_rotation_diversity(tools, PoseOptions{}));
}

// A variant keeps what the calibration needs of its pose: hand-eye, the
// direction the view is tilted toward (the rotation's axis); extrinsics, the
// board's place in the image.
TEST(PosePlan, AVariantKeepsTheViewsTiltAxisAndItsPlaceInTheImage) {
  const BoardSpec board;
  const Isometry3d board_in_base = pose(-0.38, 0.8, -0.3, -90, 0, 0);
  const Isometry3d camera_in_tool = pose(0.014, -0.009, -0.048, 0.6, -0.8, 1.5);
  const auto nominal = plan_hand_eye(board_in_base, board, camera_in_tool);
  // The board's normal in the camera frame: its x, y components are the tilt's direction and size (the
  // roll about the optical axis leaves them be).
  const auto tilt = [&](const Isometry3d& tool) {
    const Vector3d d = (tool * camera_in_tool).linear().transpose() * board_in_base.linear().col(2);
    return Eigen::Vector2d(d.x(), d.y());
  };
  for (const PoseVariant& v : fallback_variants()) {
    const auto varied = plan_hand_eye(board_in_base, board, camera_in_tool, HandEyePlan{}, v);
    ASSERT_EQ(varied.size(), nominal.size());
    for (std::size_t k = 0; k < nominal.size(); ++k) {
      const Eigen::Vector2d a = tilt(nominal[k]), b = tilt(varied[k]);
      EXPECT_GT(a.normalized().dot(b.normalized()), std::cos(10 * M_PI / 180)) << k;
      EXPECT_GT(b.norm(), 0.45 * a.norm()) << k;  // tilted at least half as far
    }
  }
  Isometry3d camera = Isometry3d::Identity();
  camera.linear() << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  camera.translation() = Vector3d(-0.24, 0.23, -0.40);
  const Isometry3d board_in_tool = pose(0.10, -0.14, 0.06, 180, 0, 90);
  const auto grid = plan_extrinsics(camera, board, board_in_tool);
  for (const PoseVariant& v : fallback_variants()) {
    const auto varied = plan_extrinsics(camera, board, board_in_tool, ExtrinsicsPlan{}, v);
    for (std::size_t k = 0; k < grid.size(); ++k) {
      const auto in_image = [&](const Isometry3d& tool) {
        const Vector3d c = proper_twin(camera).inverse() * (tool * board_in_tool * Vector3d(0.14, 0.10, 0.0));
        return Eigen::Vector2d(c.x() / c.z(), c.y() / c.z());
      };
      EXPECT_LT((in_image(varied[k]) - in_image(grid[k])).norm(), 1e-9) << k;
    }
  }
}

TEST(PosePlan, ARefusedPoseIsReplacedByTheFirstReachableVariant) {
  // Poses as points: pose k of variant v at (k, v, 0), so what was chosen is readable.
  const auto variant_index = [](const PoseVariant& v) -> int {
    if (v.tilt_scale == 1.0 && v.roll_scale == 1.0 && v.distance_change_m == 0.0) return 0;
    const auto& f = fallback_variants();
    for (std::size_t i = 0; i < f.size(); ++i)
      if (f[i].tilt_scale == v.tilt_scale && f[i].roll_scale == v.roll_scale &&
          f[i].distance_change_m == v.distance_change_m)
        return static_cast<int>(i) + 1;
    return -99;
  };
  const auto make = [&](const PoseVariant& v) {
    std::vector<Isometry3d> poses;
    for (int k = 0; k < 9; ++k) poses.push_back(pose(k, variant_index(v), 0));
    return poses;
  };
  std::vector<std::pair<int, int>> asked;
  // Pose 2 is reachable only from the second fallback on, pose 5 never; the rest as planned.
  const ReachablePlan p = choose_reachable(make, [&](const Isometry3d& t) {
    const int k = static_cast<int>(t.translation().x()), v = static_cast<int>(t.translation().y());
    asked.emplace_back(k, v);
    if (k == 2) return v >= 2;
    return k != 5;
  });
  ASSERT_EQ(p.poses.size(), 9u);
  EXPECT_EQ(p.variant[2], 2);
  EXPECT_EQ(p.poses[2].translation().y(), 2.0);
  EXPECT_EQ(p.variant[5], -1);
  EXPECT_EQ(p.poses[5].translation().y(), 0.0);  // the nominal pose, for the run to skip
  EXPECT_EQ(p.held(), 8);
  EXPECT_EQ(p.nominal(), 7);
  // In the plan's order, each pose's candidates in turn until one is taken.
  const std::size_t all = fallback_variants().size() + 1;
  EXPECT_EQ(asked.size(), 7 + 3 + all);
  EXPECT_EQ(asked[2], std::make_pair(2, 0));
  EXPECT_EQ(asked[4], std::make_pair(2, 2));
  EXPECT_EQ(asked[5], std::make_pair(3, 0));
}

arm::RobotLinkConfig shipped_link() {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  return arm::RobotLinkConfig::from_config(doc.root());
}

TEST(LinkReach, TheLinksOwnChecksFromTheJointsThePosesBeforeLeft) {
  const arm::RobotLinkConfig link = shipped_link();
  const Eigen::VectorXd home = link.model.home;
  const Isometry3d at_home = kinematics::tool_pose(link.model, home);
  LinkReach reach(link, home, 0.1, 0.3);
  std::string why;
  EXPECT_TRUE(reach.accept(at_home * pose(0.0, 0.0, 0.05), &why)) << why;  // 5 cm along the tool axis
  EXPECT_GT((reach.joints() - home).norm(), 1e-3);                       // the arm is now taken to be there
  EXPECT_NEAR((kinematics::tool_pose(link.model, reach.joints()).translation() -
               (at_home * pose(0.0, 0.0, 0.05)).translation()).norm(), 0.0, 0.005);
  EXPECT_FALSE(reach.accept(pose(10.0, 0.0, 0.0), &why));
  EXPECT_EQ(why, "pose goal outside the workspace");
  // The workspace's far corner, 1.5 m from the base: beyond the arm's reach.
  const Eigen::VectorXd before = reach.joints();
  Isometry3d far = at_home;
  far.translation() = Vector3d(0.69, 1.29, 0.29);
  EXPECT_FALSE(reach.accept(far, &why));
  EXPECT_NE(why.find("not reachable"), std::string::npos) << why;
  EXPECT_EQ(reach.joints(), before);  // a refused pose leaves the arm where it was
}

// The hand-eye plan of the calibration scenario (the board where it stands,
// the arm at the scenario's start): how many poses the link takes as
// planned, skipping the refused ones as the run does, and how many with
// refused poses replaced by a reachable variant.
TEST(LinkReach, VariantsRecoverTheHandEyePosesTheLinkWouldRefuse) {
  const test::CalibScenes scenes;
  const sim::Scenario& sc = scenes.scenario();
  const arm::RobotLinkConfig link = shipped_link();
  const Eigen::VectorXd q0 =
      sim::start_joints(link.model, Isometry3d::Identity(), sim::start_tool_pose(sc.arm)).q;
  const auto make = [&](const PoseVariant& v) {
    return plan_hand_eye(test::iso(scenes.board().pose), scenes.board().spec, test::iso(sc.arm.hand_eye),
                         HandEyePlan{}, v);
  };
  LinkReach as_planned(link, q0, 0.1, 0.3);
  int before = 0;
  for (const Isometry3d& t : make(PoseVariant{})) before += as_planned.accept(t) ? 1 : 0;
  LinkReach with_variants(link, q0, 0.1, 0.3);
  const ReachablePlan p = choose_reachable(make, [&](const Isometry3d& t) { return with_variants.accept(t); });
  std::printf("hand-eye plan, calibration scenario: %d of 12 poses reachable as planned, %d with variants\n", before,
              p.held());
  EXPECT_GT(p.held(), before);
  EXPECT_GE(p.held(), 11);
  EXPECT_NO_THROW(check_rotation_diversity(p.poses, PoseOptions{}));
}

// ---- the runner ----

// The robot link as the runner sees it: obeys signed pose goals of the
// controller it is bound to, moves the tool toward the goal at a bounded
// speed, publishes ROBOT_STATE at 100 Hz. It may refuse goals (unreachable),
// fault, or fall silent.
class StandInLink final : public rt::Node {
 public:
  explicit StandInLink(Isometry3d start) : rt::Node("robot-link"), tool_(start) {}
  std::set<int> refuse;  // goal indices (in order of first sight) refused, as the link refuses an unreachable goal
  std::set<int> ignore;  // ... never reached and never refused (the arm blocked)
  bool fault = false, silent = false;
  std::vector<std::pair<rt::Micros, Isometry3d>> goals_obeyed;
  int stops = 0, refused_signatures = 0;
  // The time the tool spent within 1 mm of each goal, still and IDLE (stopped: what the calibration uses).
  std::map<int64_t, rt::Micros> rest_at_goal;

 protected:
  void on_attach() override {
    security::AuthorityConfig cfg;
    cfg.key = security::kSimKeyName;
    cfg.controller = "servo-controller";
    authority_ = std::make_unique<security::Authority>(cfg, security::sim_key(), clock(),
                                                       [this](const std::string& c, int64_t n) { count(c, n); });
    advertise(channels::kRobotState);
    subscribe<robot_command_t>(channels::kRobotCommand, [this](const robot_command_t& c) { on_command(c); });
    every(10 * rt::kMilli, [this] { step(); });
  }

 private:
  void on_command(const robot_command_t& c) {
    if (!authority_->admit_from_controller("ROBOT_COMMAND", c)) {
      ++refused_signatures;
      return;
    }
    if (c.type == robot_command_t::TYPE_STOP) {
      ++stops;
      goal_.reset();
      return;
    }
    if (c.type != robot_command_t::TYPE_POSE_GOAL) return;
    if (!seen_.count(c.goal_id)) {
      seen_.insert(c.goal_id);
      order_.push_back(c.goal_id);
    }
    const int index = static_cast<int>(std::find(order_.begin(), order_.end(), c.goal_id) - order_.begin());
    if (refuse.count(index)) {
      limit_text_ = "command seq " + std::to_string(c.header.seq) + " refused: pose goal not reachable: out of reach";
      return;
    }
    if (ignore.count(index)) return;
    if (!goal_ || goal_id_ != c.goal_id) goals_obeyed.emplace_back(now(), geometry::to_isometry(c.pose_goal));
    goal_ = last_goal_ = geometry::to_isometry(c.pose_goal);
    goal_id_ = c.goal_id;
    speed_ = c.max_linear_speed;
  }
  void step() {
    Vector3d v = Vector3d::Zero();
    if (goal_) {
      const Vector3d d = goal_->translation() - tool_.translation();
      const double s = std::min(d.norm(), speed_ * 0.01);
      if (d.norm() > 0) v = d.normalized() * s / 0.01;
      tool_.translation() += v * 0.01;
      const Eigen::Quaterniond q(tool_.linear()), g(goal_->linear());
      const double angle = q.angularDistance(g);
      tool_.linear() = (angle <= 0.005 ? g : q.slerp(0.005 / angle, g)).toRotationMatrix();
    } else if (last_goal_ && (last_goal_->translation() - tool_.translation()).norm() < 1e-3) {
      rest_at_goal[goal_id_] += 10 * rt::kMilli;
    }
    if (silent) return;
    robot_state_t s{};
    s.header.utime = now();
    s.mode = fault ? robot_state_t::MODE_FAULT : goal_ ? robot_state_t::MODE_MOVING : robot_state_t::MODE_IDLE;
    s.fault_text = fault ? "joint 3: following error" : limit_text_;
    s.tool_pose = geometry::to_pose(tool_);
    s.camera_pose = s.tool_pose;
    for (int i = 0; i < 3; ++i) s.tool_twist.linear[i] = v[i];
    publish(channels::kRobotState, s);
  }

  Isometry3d tool_;
  std::optional<Isometry3d> goal_, last_goal_;
  int64_t goal_id_ = 0;
  double speed_ = 0.1;
  std::set<int64_t> seen_;
  std::string limit_text_;
  std::vector<int64_t> order_;
  std::unique_ptr<security::Authority> authority_;
};

struct RunnerTest : ::testing::Test {
  std::vector<Isometry3d> poses{pose(0.3, 0.2, 0.1), pose(0.35, 0.2, 0.1, 10, 0, 0), pose(0.3, 0.25, 0.12, 0, 12, 5),
                                pose(0.28, 0.2, 0.1, -8, -8, 0)};
  rt::SimRunner runner{1'000'000'000};
  StandInLink link{pose(0.25, 0.2, 0.1)};
  std::unique_ptr<PlanRunner> plan;
  std::vector<std::string> lines;

  void start(PlanRunConfig config = {}, const std::string& sender = "servo-controller") {
    config.poses = poses;
    config.pose_timeout_s = 5;
    plan = std::make_unique<PlanRunner>(config, security::sim_key(), sender);
    plan->on_progress = [this](const std::string& l) { lines.push_back(l); };
    runner.add(link);
    runner.add(*plan);
    runner.start();
  }
  void run_for(double s) { runner.run_until(runner.clock().now() + rt::from_seconds(s)); }
};

TEST_F(RunnerTest, VisitsEveryPoseRestsThereAndStopsTheArmAtTheEnd) {
  start();
  run_for(60);
  ASSERT_EQ(plan->outcome(), PlanRunner::Outcome::kDone) << plan->why();
  EXPECT_EQ(plan->reached(), 4);
  EXPECT_TRUE(plan->skipped().empty());
  EXPECT_EQ(link.refused_signatures, 0);
  ASSERT_EQ(link.goals_obeyed.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_TRUE(link.goals_obeyed[k].second.isApprox(poses[k], 1e-9)) << k;
  // At rest at each goal for the dwell (1 s) before the next was sent.
  ASSERT_EQ(link.rest_at_goal.size(), 4u);
  for (const auto& [id, rest] : link.rest_at_goal) EXPECT_GE(rest, 990 * rt::kMilli) << id;
  EXPECT_EQ(link.stops, 5);  // at each pose, and at the end
  EXPECT_TRUE(runner.stop_requested());
  EXPECT_EQ(runner.exit_code(), 0);
  EXPECT_EQ(lines.back(), "plan done: 4 of 4 poses reached");
}

TEST_F(RunnerTest, ARefusedPoseIsSkippedAtOnceWithTheLinksReason) {
  link.refuse = {1};
  start();
  run_for(60);
  ASSERT_EQ(plan->outcome(), PlanRunner::Outcome::kDone) << plan->why();
  EXPECT_EQ(plan->reached(), 3);
  EXPECT_EQ(plan->skipped(), std::vector<int>{1});
  EXPECT_EQ(link.goals_obeyed.size(), 3u);
  EXPECT_NE(std::find(lines.begin(), lines.end(), "pose 2/4 skipped: pose goal not reachable: out of reach"),
            lines.end());
  // The refusal of pose 2 is not taken for one of pose 3 (its text stays in the state until another is refused).
  EXPECT_EQ(lines.back(), "plan done: 3 of 4 poses reached, 1 skipped");
}

TEST_F(RunnerTest, APoseNeverReachedIsSkippedAfterItsTimeout) {
  link.ignore = {2};
  start();
  run_for(60);
  ASSERT_EQ(plan->outcome(), PlanRunner::Outcome::kDone) << plan->why();
  EXPECT_EQ(plan->reached(), 3);
  EXPECT_EQ(plan->skipped(), std::vector<int>{2});
  EXPECT_NE(lines[2].find("pose 3/4 not reached and held in 5 s: skipped"), std::string::npos) << lines[2];
}

TEST_F(RunnerTest, AFaultStopsTheRun) {
  start();
  run_for(1.5);
  link.fault = true;
  const int stops = link.stops;
  run_for(1);
  EXPECT_EQ(plan->outcome(), PlanRunner::Outcome::kAborted);
  EXPECT_NE(plan->why().find("FAULT: joint 3: following error"), std::string::npos) << plan->why();
  EXPECT_EQ(link.stops, stops + 1);
  EXPECT_EQ(runner.exit_code(), 1);
}

TEST_F(RunnerTest, ASilentRobotLinkStopsTheRun) {
  start();
  run_for(1.5);
  link.silent = true;
  const int stops = link.stops;
  run_for(1);
  EXPECT_EQ(plan->outcome(), PlanRunner::Outcome::kAborted);
  EXPECT_NE(plan->why().find("ROBOT_STATE stopped coming"), std::string::npos) << plan->why();
  EXPECT_EQ(link.stops, stops + 1);
}

TEST_F(RunnerTest, NothingMovesWithoutARobotState) {
  link.silent = true;
  start();
  run_for(2);
  EXPECT_EQ(plan->outcome(), PlanRunner::Outcome::kAborted);
  EXPECT_NE(plan->why().find("is the robot link running?"), std::string::npos) << plan->why();
  EXPECT_TRUE(link.goals_obeyed.empty());
}

TEST_F(RunnerTest, TheOperatorsStopStopsTheArm) {
  start();
  run_for(0.3);  // on the way to the first pose
  const int stops = link.stops;
  plan->begin_shutdown();
  run_for(0.1);
  EXPECT_EQ(plan->outcome(), PlanRunner::Outcome::kAborted);
  EXPECT_EQ(plan->why(), "stopped by the operator");
  EXPECT_EQ(link.stops, stops + 1);
  EXPECT_TRUE(plan->shutdown_complete());
}

TEST_F(RunnerTest, CommandsSignedAsAnotherSenderAreNotObeyed) {
  start({}, "calibration");
  run_for(3);
  EXPECT_GT(link.refused_signatures, 0);
  EXPECT_TRUE(link.goals_obeyed.empty());
}

// ---- views in sensor pixels ----

// A camera that bins its sensor (the simulator's 640 x 480 sensor published at
// 320 x 240, as a field camera may) gives views in sensor pixels: the pixels
// of every calibration file and of the processes that read them.
TEST(CalibrationNode, ViewsOfABinnedFrameAreInSensorPixels) {
  test::CalibScenes scenes;
  const auto& camera = scenes.scenario().hand_camera;
  const cv::Mat gray =
      scenes.render(camera, test::placement(Isometry3d::Identity()), scenes.board_in_camera(0.45, 0, 0, 10, -8, 3));
  ASSERT_EQ(gray.cols, 320);
  const BoardView direct = detect_board(gray, scenes.cv_board(), false);
  ASSERT_GE(direct.ids.size(), 20u);

  for (const cv::Size sensor : {cv::Size(640, 480), cv::Size(320, 240)}) {
    CalibrationNodeConfig cfg;
    cfg.board = scenes.board().spec;
    CalibrationNode node(cfg);
    rt::SimRunner runner(1'000'000);
    runner.add(node);
    runner.start();
    cv::Mat bgr;
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    image_t img = sim::SimCameras::make_image(bgr, "bgr8", 0, sensor.width, sensor.height);  // as the simulator publishes
    img.header.utime = 1'000'000;
    runner.inject(channels::kCameraHand, img);
    node.finish();
    ASSERT_EQ(node.collector().views().size(), 1u) << sensor;
    const BoardView& v = node.collector().views().front();
    EXPECT_EQ(v.image_size, sensor);
    ASSERT_EQ(v.ids, direct.ids);
    const double s = sensor.width / 320.0;
    for (std::size_t i = 0; i < v.corners.size(); ++i) {
      EXPECT_FLOAT_EQ(v.corners[i].x, static_cast<float>((direct.corners[i].x + 0.5) * s - 0.5)) << i;
      EXPECT_FLOAT_EQ(v.corners[i].y, static_cast<float>((direct.corners[i].y + 0.5) * s - 0.5)) << i;
    }
  }
}

}  // namespace
}  // namespace harvest::calib
