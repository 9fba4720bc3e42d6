#include "calib/pose_plan.hpp"

#include <cmath>

namespace harvest::calib {

namespace {
constexpr double kDeg = M_PI / 180.0;
}

Eigen::Isometry3d board_facing_camera(const BoardSpec& board, double depth, double ox, double oy, double rx_deg,
                                      double ry_deg, double rz_deg) {
  const Eigen::Vector3d half(board.squares_x * board.square_m / 2, board.squares_y * board.square_m / 2, 0.0);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(rx_deg * kDeg, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(ry_deg * kDeg, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rz_deg * kDeg, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  t.translation() = Eigen::Vector3d(ox, oy, depth) - r * half;  // the centre, not the origin corner, at (ox, oy, depth)
  return t;
}

Eigen::Isometry3d proper_twin(const Eigen::Isometry3d& camera) {
  if (camera.linear().determinant() > 0) return camera;
  Eigen::Isometry3d twin = camera;
  twin.linear() = camera.linear() * Eigen::Vector3d(-1, 1, 1).asDiagonal();
  return twin;
}

std::vector<Eigen::Isometry3d> plan_hand_eye(const Eigen::Isometry3d& board_in_base, const BoardSpec& board,
                                             const Eigen::Isometry3d& camera_in_tool, const HandEyePlan& plan) {
  std::vector<Eigen::Isometry3d> tools;
  for (int k = 0; k < plan.poses; ++k) {
    const double a = k * 2 * M_PI / plan.poses;
    // The board in the camera; the camera in the base is then board * that^-1.
    const Eigen::Isometry3d in_camera = board_facing_camera(
        board, plan.distance_m + plan.depth_step_m * (k % 5), plan.offset_m * std::cos(a), plan.offset_m * std::sin(a),
        plan.tilt_deg * std::sin(a), plan.tilt_deg * std::cos(a), plan.roll_deg * std::sin(2 * a));
    const Eigen::Isometry3d camera = board_in_base * in_camera.inverse();
    tools.push_back(camera * camera_in_tool.inverse());
  }
  return tools;
}

std::vector<Eigen::Isometry3d> plan_extrinsics(const Eigen::Isometry3d& camera_in_base, const BoardSpec& board,
                                               const Eigen::Isometry3d& board_in_tool, const ExtrinsicsPlan& plan) {
  // A proper board seen by an improper camera is placed in the camera's proper twin.
  const Eigen::Isometry3d twin = proper_twin(camera_in_base);
  std::vector<Eigen::Isometry3d> tools;
  int k = 0;
  for (const double sy : {-1.0, 0.0, 1.0})
    for (const double sx : {-1.0, 0.0, 1.0}) {
      const Eigen::Isometry3d in_camera = board_facing_camera(
          board, plan.distance_m + plan.depth_step_m * (k % 3), sx * plan.spread_x_m, sy * plan.spread_y_m,
          k % 2 ? plan.tilt_deg : -0.8 * plan.tilt_deg, k % 3 == 0 ? plan.tilt_deg : -0.8 * plan.tilt_deg,
          plan.roll_step_deg * (k % 4) - 1.5 * plan.roll_step_deg);
      tools.push_back(twin * in_camera * board_in_tool.inverse());
      ++k;
    }
  return tools;
}

}  // namespace harvest::calib
