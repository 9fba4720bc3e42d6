// The arm-moved calibrations as a field engineer runs them, against the
// simulator: config/sets/sim-calibration.yaml (harvest-sim in devices mode,
// the field's harvest-robot-link on a virtual CAN bus) recording the camera
// and the arm; `harvest-calibrate plan PROCEDURE --run` finds the board and
// moves the arm through the robot link; `harvest-calibrate PROCEDURE --log`
// on the recording recovers the simulator's truth.
// * hand-eye: the board of config/scenarios/calibration.yaml on its stand,
//   the true camera-in-hand pose;
// * extrinsics: the board of config/scenarios/calibration_extrinsics.yaml
//   clamped to the tool, the fixed camera's true mounting (and the board's on
//   the tool).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <regex>

#include "geometry/camera_model.hpp"
#include "geometry/transform_file.hpp"
#include "sim/ports.hpp"
#include "sim/scenario.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {

std::string read(const fs::path& p) {
  std::ifstream f(p);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

Eigen::Isometry3d iso(const harvest::sim::Placement& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.rotation;
  t.translation() = p.position;
  return t;
}

struct Off {
  double mm, deg;
};
// Improper frames (the thesis's fixed camera) compare as well: R_a^T R_b is proper.
Off off(const Eigen::Isometry3d& got, const Eigen::Isometry3d& truth) {
  return {1000 * (got.translation() - truth.translation()).norm(),
          Eigen::AngleAxisd(Eigen::Matrix3d(got.linear().transpose() * truth.linear())).angle() * 180 / M_PI};
}

// The set recording `channels` with `scenario`, `harvest-calibrate plan
// PROCEDURE --run` with `plan_args` through it, then `harvest-calibrate
// PROCEDURE --log` on the recording with the camera's true intrinsics
// (the procedure is what is tested), written to dir/out.yaml.
struct PlannedRun {
  std::string plan_out, solve_out;
  int held = 0, planned = 0;
};
PlannedRun plan_record_solve(const ht::TempDir& dir, const std::string& procedure, const std::string& scenario,
                             const std::string& channels, const harvest::sim::CameraSetup& camera,
                             const std::vector<std::string>& plan_args) {
  PlannedRun r;
  const std::string url = ht::unique_lcm_url();
  const int port = harvest::sim::free_port(false);
  ht::ChildProcess set({ht::bin("harvest-launch"), ht::source_path("config/sets/sim-calibration.yaml"), "--lcm-url",
                        url, "--set", "site.can_bus=" + ht::unique_can_bus(), "--set",
                        "site.board_port=" + std::to_string(port), "--set",
                        "site.calibration_scenario=" + ht::source_path(scenario), "--set", "recording.enabled=true",
                        "--set", "recording.folder=" + dir.path().string(), "--set", "recording.channels=" + channels},
                       dir / "launch.log");
  std::vector<std::string> argv{ht::bin("harvest-calibrate"), "plan",  procedure, "--lcm-url", url,
                                "--robot-link-config", ht::source_path("config/arm/robot_link.yaml"),
                                "--locate-timeout",    "30",       "--run"};
  argv.insert(argv.end(), plan_args.begin(), plan_args.end());
  ht::ChildProcess plan(argv, dir / "plan.log");
  const int plan_rc = plan.wait(300s);
  r.plan_out = plan.output();
  std::printf("%s", r.plan_out.c_str());
  set.stop(20s, SIGINT);
  EXPECT_EQ(plan_rc, 0) << r.plan_out << "\n--- set:\n" << set.output();
  std::smatch m;
  EXPECT_TRUE(std::regex_search(r.plan_out, m, std::regex(R"(plan done: (\d+) of (\d+) poses reached)"))) << r.plan_out;
  if (!m.empty()) {
    r.held = std::stoi(m[1]);
    r.planned = std::stoi(m[2]);
  }
  // Every pose reached and held, or refused by the link as out of reach; at most one that the offline
  // reachability check passed and the live link did not reach (seen once: a tilt x0.5 variant, 2026-12-04).
  std::size_t not_reached = 0;
  for (auto at = r.plan_out.find("not reached and held"); at != std::string::npos;
       at = r.plan_out.find("not reached and held", at + 1))
    ++not_reached;
  EXPECT_LE(not_reached, 1u) << r.plan_out;

  fs::path log;
  for (const auto& e : fs::directory_iterator(dir.path()))
    if (e.path().filename().string().rfind("sim-calibration-", 0) == 0) log = e.path();
  EXPECT_FALSE(log.empty()) << set.output();
  if (log.empty()) return r;

  // The camera's true intrinsics at sensor size (its frames are binned 2:1).
  const auto& model = camera.model;
  model.zoomed(0, 0, model.width, model.height, camera.sensor_width, camera.sensor_height)
      .save(dir / "camera_true.yaml");
  ht::ChildProcess solve({ht::bin("harvest-calibrate"), procedure, "--log", log.string(), "--intrinsics",
                          (dir / "camera_true.yaml").string(), "-o", (dir / "out.yaml").string()},
                         dir / "solve.log");
  EXPECT_EQ(solve.wait(120s), 0) << solve.output();
  r.solve_out = solve.output();
  std::printf("%s", r.solve_out.c_str());
  return r;
}

TEST(CalibrationPlan, HandEyeFromAPlannedRunThroughTheRobotLink) {
  ht::TempDir dir;
  const auto sc = harvest::sim::load_scenario(ht::source_path("config/scenarios/calibration.yaml"));
  // The software's estimates as shipped: the plan needs only a rough idea of where the board is.
  const PlannedRun run = plan_record_solve(
      dir, "hand-eye", "config/scenarios/calibration.yaml", "CAMERA_HAND|ROBOT_STATE|ROBOT_COMMAND", sc.hand_camera,
      {"--intrinsics", ht::source_path("config/cameras/hand.yaml"), "--hand-eye",
       ht::source_path("config/cameras/hand_eye.yaml")});
  ASSERT_FALSE(HasFailure());
  // The poses the link would refuse as planned (4 of 12 here) are replaced by reachable variants.
  EXPECT_GE(run.held, 11);

  const Eigen::Isometry3d got =
      harvest::geometry::load_transform_file(dir / "out.yaml", harvest::geometry::Handedness::kProper);
  const Off e = off(got, iso(sc.arm.hand_eye));
  std::printf("hand-eye through the process set: %d of %d poses held; %.2f mm, %.3f deg off the truth\n", run.held,
              run.planned, e.mm, e.deg);
  EXPECT_LE(e.mm, 2.0);
  EXPECT_LE(e.deg, 0.2);
  // And far from the shipped estimate it started from (the point of calibrating).
  const Eigen::Isometry3d shipped = harvest::geometry::load_transform_file(
      ht::source_path("config/cameras/hand_eye.yaml"), harvest::geometry::Handedness::kProper);
  EXPECT_GT(off(shipped, iso(sc.arm.hand_eye)).mm, 5.0);
}

TEST(CalibrationPlan, FixedCameraExtrinsicFromABoardOnTheToolThroughTheRobotLink) {
  ht::TempDir dir;
  const auto sc = harvest::sim::load_scenario(ht::source_path("config/scenarios/calibration_extrinsics.yaml"));
  ASSERT_EQ(sc.boards.size(), 1u);
  ASSERT_TRUE(sc.boards[0].on_tool);
  const PlannedRun run = plan_record_solve(
      dir, "extrinsics", "config/scenarios/calibration_extrinsics.yaml", "CAMERA_FIXED|ROBOT_STATE|ROBOT_COMMAND",
      sc.fixed_camera,
      {"--intrinsics", ht::source_path("config/cameras/fixed.yaml"), "--extrinsic",
       ht::source_path("config/cameras/fixed_extrinsic.yaml")});
  ASSERT_FALSE(HasFailure());
  EXPECT_GE(run.held, 8);

  // The true mounting in the robot base frame (the scenario's arm mounting is the identity).
  const Eigen::Isometry3d truth = iso(sc.arm.mounting).inverse() * iso(sc.fixed_camera_truth);
  const Eigen::Isometry3d got =
      harvest::geometry::load_transform_file(dir / "out.yaml", harvest::geometry::Handedness::kReflectionAllowed);
  EXPECT_LT(got.linear().determinant(), 0);  // the thesis's improper frame, as the reconstructor reads it
  const Off e = off(got, truth);
  // The board on the tool, from the file's comment.
  std::smatch m;
  const std::string text = read(dir / "out.yaml");
  ASSERT_TRUE(std::regex_search(
      text, m,
      std::regex(R"(board on the tool: translation (\S+), (\S+), (\S+) mm, rotation (\S+) deg about (\S+), (\S+), (\S+))")))
      << text;
  Eigen::Isometry3d board = Eigen::Isometry3d::Identity();
  board.translation() = Eigen::Vector3d(std::stod(m[1]), std::stod(m[2]), std::stod(m[3])) / 1000;
  board.linear() = Eigen::AngleAxisd(std::stod(m[4]) * M_PI / 180,
                                     Eigen::Vector3d(std::stod(m[5]), std::stod(m[6]), std::stod(m[7])).normalized())
                       .toRotationMatrix();
  const Off b = off(board, iso(sc.boards[0].pose));
  std::printf(
      "fixed camera through the process set: %d of %d poses held; %.2f mm, %.3f deg off the truth; the board on the "
      "tool %.2f mm, %.3f deg off\n",
      run.held, run.planned, e.mm, e.deg, b.mm, b.deg);
  EXPECT_LE(e.mm, 5.0);
  EXPECT_LE(e.deg, 0.3);
  EXPECT_LE(b.mm, 5.0);
  EXPECT_LE(b.deg, 0.3);
  // And far from the shipped (hand-measured, table 6-3) estimate it started from.
  const Eigen::Isometry3d shipped = harvest::geometry::load_transform_file(
      ht::source_path("config/cameras/fixed_extrinsic.yaml"), harvest::geometry::Handedness::kReflectionAllowed);
  std::printf("the shipped estimate: %.2f mm, %.3f deg off the truth\n", off(shipped, truth).mm,
              off(shipped, truth).deg);
  EXPECT_GT(off(shipped, truth).mm, 5.0);
}

}  // namespace
