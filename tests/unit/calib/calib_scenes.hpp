// Calibration views with known truth, rendered in process by the simulator
// (config/scenarios/calibration.yaml: its cameras' true intrinsics and
// distortion, the true camera-in-hand pose, the fixed camera's true pose).
#pragma once

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "calib/pose_plan.hpp"
#include "calib/views.hpp"
#include "sim/board.hpp"
#include "sim/renderer.hpp"
#include "sim/scenario.hpp"
#include "sim/scene.hpp"

namespace harvest::calib::test {

using sim::Mat3;
using sim::Placement;
using sim::Vec3;

inline Eigen::Isometry3d iso(const Placement& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.rotation;
  t.translation() = p.position;
  return t;
}
inline Placement placement(const Eigen::Isometry3d& t) { return {t.linear(), t.translation()}; }

inline Mat3 rot(double rx_deg, double ry_deg, double rz_deg) {
  return (Eigen::AngleAxisd(rx_deg * M_PI / 180, Vec3::UnitX()) *
          Eigen::AngleAxisd(ry_deg * M_PI / 180, Vec3::UnitY()) * Eigen::AngleAxisd(rz_deg * M_PI / 180, Vec3::UnitZ()))
      .toRotationMatrix();
}

class CalibScenes {
 public:
  CalibScenes() : sc_(sim::load_scenario("config/scenarios/calibration.yaml")) {
    empty_ = sc_;
    empty_.fruit.clear();
    scene_ = std::make_unique<sim::Scene>(empty_);
  }
  const sim::Scenario& scenario() const { return sc_; }
  const sim::BoardSetup& board() const { return sc_.boards.at(0); }
  cv::Ptr<cv::aruco::CharucoBoard> cv_board() const { return make_board(board().spec); }

  // The board centred `offset` (camera x, y at `depth`), turned by rx, ry, rz
  // about its centre, in a proper camera frame.
  Placement board_in_camera(double depth, double ox, double oy, double rx, double ry, double rz) const {
    return placement(board_facing_camera(board().spec, depth, ox, oy, rx, ry, rz));
  }

  // A grey frame of `camera` at `camera_pose` (base frame) with the board at `board_pose`.
  cv::Mat render(const sim::CameraSetup& camera, const Placement& camera_pose, const Placement& board_pose,
                 uint64_t seed = 1) const {
    auto prim = std::make_shared<sim::BoardPrimitive>(board().spec, board_pose);
    sim::Renderer r(camera.model, camera.noise_std, seed);
    r.add_primitive(prim);
    cv::Mat gray;
    cv::cvtColor(r.render(*scene_, camera_pose), gray, cv::COLOR_BGR2GRAY);
    return gray;
  }

  // Hand-camera views for intrinsics: the board across the image at 0.45-0.7 m, tilted about both axes.
  // `mirrored`: seen through an improper camera frame (as the fixed camera sees a proper board).
  std::vector<cv::Mat> intrinsics_frames(const sim::CameraSetup& camera, bool mirrored = false) const {
    // The board is placed in the camera's proper twin; an improper camera is its mirror image.
    const Placement pose{mirrored ? Mat3(Vec3(-1, 1, 1).asDiagonal()) : Mat3::Identity(), Vec3::Zero()};
    const auto in_base = [](const Placement& in_twin) { return in_twin; };
    std::vector<cv::Mat> out;
    int k = 0;
    for (const auto& [rx, ry] :
         {std::pair{35.0, 0.0}, std::pair{0.0, 35.0}, std::pair{-35.0, 0.0}, std::pair{0.0, -35.0}})
      for (const double oy : {-0.1, 0.0, 0.1})
        for (const double ox : {-0.14, 0.0, 0.14}) {
          const double depth = 0.45 + 0.05 * (k % 4);
          out.push_back(
              render(camera, pose, in_base(board_in_camera(depth, ox, oy, rx, ry, 6.0 * (k % 5) - 12.0)), 10 + k));
          ++k;
        }
    // The image's corners, where the distortion is largest: the board's own corner in them.
    for (const double sx : {-1.0, 1.0})
      for (const double sy : {-1.0, 1.0})
        for (const double rz : {-10.0, 10.0}) {
          out.push_back(render(
              camera, pose, in_base(board_in_camera(0.5, 0.135 * sx, 0.105 * sy, 15.0 * sy, -15.0 * sx, rz)), 10 + k));
          ++k;
        }
    // Two near views filling the frame, nearly square on.
    out.push_back(render(camera, pose, in_base(board_in_camera(0.42, 0.0, 0.0, 10, -8, 3)), 60));
    out.push_back(render(camera, pose, in_base(board_in_camera(0.45, 0.01, -0.01, -12, 6, -4)), 61));
    return out;
  }

  // Tool poses about the board on its stand for hand-eye (harvest-calibrate
  // plan's, with the true hand-eye); `one_axis`: all rolls about the optical
  // axis, a degenerate dataset.
  std::vector<Eigen::Isometry3d> hand_eye_tool_poses(bool one_axis = false) const {
    const Eigen::Isometry3d board_pose = iso(board().pose);
    const Eigen::Isometry3d x = iso(sc_.arm.hand_eye);
    if (!one_axis) return plan_hand_eye(board_pose, board().spec, x);
    std::vector<Eigen::Isometry3d> tools;
    for (int k = 0; k < 12; ++k)
      tools.push_back(board_pose * iso(board_in_camera(0.5, 0.0, 0.0, 0.0, 0.0, 30.0 * k - 150.0)).inverse() *
                      x.inverse());
    return tools;
  }

  BoardView hand_view(const Eigen::Isometry3d& tool, uint64_t seed) const {
    const Eigen::Isometry3d camera = tool * iso(sc_.arm.hand_eye);
    BoardView v = detect_board(render(sc_.hand_camera, placement(camera), board().pose, seed), cv_board(), true);
    v.tool_pose = tool;
    return v;
  }

  // The board carried by the tool (its frame in the tool's), for the fixed camera.
  static Eigen::Isometry3d board_in_tool() {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = rot(180.0, 0.0, 90.0);
    t.translation() = Vec3(0.10, -0.14, 0.06);
    return t;
  }

  // Tool poses that show the carried board to the fixed camera across its
  // image (harvest-calibrate plan's, with the true extrinsic).
  std::vector<Eigen::Isometry3d> extrinsics_tool_poses() const {
    return plan_extrinsics(iso(sc_.fixed_camera_truth), board().spec, board_in_tool());
  }

  BoardView fixed_view(const Eigen::Isometry3d& tool, uint64_t seed) const {
    const Eigen::Isometry3d board_pose = tool * board_in_tool();
    BoardView v =
        detect_board(render(sc_.fixed_camera, sc_.fixed_camera_truth, placement(board_pose), seed), cv_board(), true);
    v.tool_pose = tool;
    return v;
  }

 private:
  sim::Scenario sc_, empty_;
  std::unique_ptr<sim::Scene> scene_;
};

}  // namespace harvest::calib::test
