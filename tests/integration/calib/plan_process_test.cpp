// The hand-eye calibration as a field engineer runs it, against the
// simulator: config/sets/sim-calibration.yaml (harvest-sim in devices mode
// with the board of config/scenarios/calibration.yaml on its stand, the
// field's harvest-robot-link on a virtual CAN bus) recording the cameras and
// the arm; `harvest-calibrate plan hand-eye --run` finds the board and moves
// the arm through the robot link; `harvest-calibrate hand-eye --log` on the
// recording recovers the simulator's true camera-in-hand pose.
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

TEST(CalibrationPlan, HandEyeFromAPlannedRunThroughTheRobotLink) {
  ht::TempDir dir;
  const std::string url = ht::unique_lcm_url();
  const int port = harvest::sim::free_port(false);
  ht::ChildProcess set(
      {ht::bin("harvest-launch"), ht::source_path("config/sets/sim-calibration.yaml"), "--lcm-url", url, "--set",
       "site.can_bus=" + ht::unique_can_bus(), "--set", "site.board_port=" + std::to_string(port), "--set",
       "recording.enabled=true", "--set", "recording.folder=" + dir.path().string(), "--set",
       "recording.channels=CAMERA_HAND|ROBOT_STATE|ROBOT_COMMAND"},
      dir / "launch.log");

  // The software's estimates as shipped: the plan needs only a rough idea of where the board is.
  ht::ChildProcess plan({ht::bin("harvest-calibrate"), "plan", "hand-eye", "--lcm-url", url, "--intrinsics",
                         ht::source_path("config/cameras/hand.yaml"), "--hand-eye",
                         ht::source_path("config/cameras/hand_eye.yaml"), "--locate-timeout", "30", "--run"},
                        dir / "plan.log");
  const int plan_rc = plan.wait(300s);
  const std::string plan_out = plan.output();
  std::printf("%s", plan_out.c_str());
  set.stop(20s, SIGINT);
  ASSERT_EQ(plan_rc, 0) << plan_out << "\n--- set:\n" << set.output();
  // Every pose reached and held, or refused by the link as out of reach; at least 8 held.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(plan_out, m, std::regex(R"(plan done: (\d+) of (\d+) poses reached)"))) << plan_out;
  EXPECT_GE(std::stoi(m[1]), 8);
  EXPECT_EQ(plan_out.find("not reached and held"), std::string::npos) << plan_out;

  fs::path log;
  for (const auto& e : fs::directory_iterator(dir.path()))
    if (e.path().filename().string().rfind("sim-calibration-", 0) == 0) log = e.path();
  ASSERT_FALSE(log.empty()) << set.output();

  // The hand camera's true intrinsics at sensor size (its frames are binned 2:1): the hand-eye is what is tested.
  const harvest::sim::Scenario sc = harvest::sim::load_scenario(ht::source_path("config/scenarios/calibration.yaml"));
  const auto& model = sc.hand_camera.model;
  const harvest::geometry::CameraModel sensor =
      model.zoomed(0, 0, model.width, model.height, sc.hand_camera.sensor_width, sc.hand_camera.sensor_height);
  sensor.save(dir / "hand_true.yaml");
  ht::ChildProcess solve({ht::bin("harvest-calibrate"), "hand-eye", "--log", log.string(), "--intrinsics",
                          (dir / "hand_true.yaml").string(), "-o", (dir / "hand_eye.yaml").string()},
                         dir / "solve.log");
  ASSERT_EQ(solve.wait(120s), 0) << solve.output();
  std::printf("%s", solve.output().c_str());

  const Eigen::Isometry3d got =
      harvest::geometry::load_transform_file(dir / "hand_eye.yaml", harvest::geometry::Handedness::kProper);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = sc.arm.hand_eye.rotation;
  truth.translation() = sc.arm.hand_eye.position;
  const double position_mm = 1000 * (got.translation() - truth.translation()).norm();
  const double rotation_deg = Eigen::AngleAxisd(got.linear().transpose() * truth.linear()).angle() * 180 / M_PI;
  std::printf("hand-eye through the process set: %.2f mm, %.3f deg off the truth\n", position_mm, rotation_deg);
  EXPECT_LE(position_mm, 2.0);
  EXPECT_LE(rotation_deg, 0.2);
  // And far from the shipped estimate it started from (the point of calibrating).
  const Eigen::Isometry3d shipped = harvest::geometry::load_transform_file(
      ht::source_path("config/cameras/hand_eye.yaml"), harvest::geometry::Handedness::kProper);
  EXPECT_GT(1000 * (shipped.translation() - truth.translation()).norm(), 5.0);
}

}  // namespace
