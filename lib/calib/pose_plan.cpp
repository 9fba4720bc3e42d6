#include "calib/pose_plan.hpp"

#include <algorithm>
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

const std::vector<PoseVariant>& fallback_variants() {
  static const std::vector<PoseVariant> v{{1.0, -1.0, 0.0},  {0.7, 1.0, 0.0},  {0.7, -1.0, 0.0},
                                          {0.5, 0.0, 0.0},   {1.0, 1.0, -0.05}, {1.0, 1.0, 0.05},
                                          {0.6, 0.0, -0.05}, {0.6, 0.0, 0.05}};
  return v;
}

std::vector<Eigen::Isometry3d> plan_hand_eye(const Eigen::Isometry3d& board_in_base, const BoardSpec& board,
                                             const Eigen::Isometry3d& camera_in_tool, const HandEyePlan& plan,
                                             const PoseVariant& variant) {
  std::vector<Eigen::Isometry3d> tools;
  const double tilt = plan.tilt_deg * variant.tilt_scale, roll = plan.roll_deg * variant.roll_scale;
  for (int k = 0; k < plan.poses; ++k) {
    const double a = k * 2 * M_PI / plan.poses;
    // The board in the camera; the camera in the base is then board * that^-1.
    const Eigen::Isometry3d in_camera = board_facing_camera(
        board, plan.distance_m + plan.depth_step_m * (k % 5) + variant.distance_change_m, plan.offset_m * std::cos(a),
        plan.offset_m * std::sin(a), tilt * std::sin(a), tilt * std::cos(a), roll * std::sin(2 * a));
    const Eigen::Isometry3d camera = board_in_base * in_camera.inverse();
    tools.push_back(camera * camera_in_tool.inverse());
  }
  return tools;
}

std::vector<Eigen::Isometry3d> plan_extrinsics(const Eigen::Isometry3d& camera_in_base, const BoardSpec& board,
                                               const Eigen::Isometry3d& board_in_tool, const ExtrinsicsPlan& plan,
                                               const PoseVariant& variant) {
  // A proper board seen by an improper camera is placed in the camera's proper twin.
  const Eigen::Isometry3d twin = proper_twin(camera_in_base);
  std::vector<Eigen::Isometry3d> tools;
  const double tilt = plan.tilt_deg * variant.tilt_scale, roll_step = plan.roll_step_deg * variant.roll_scale;
  // The grid's offsets scale with the distance, so the board keeps its place in the image.
  int k = 0;
  for (const double sy : {-1.0, 0.0, 1.0})
    for (const double sx : {-1.0, 0.0, 1.0}) {
      const double depth = plan.distance_m + plan.depth_step_m * (k % 3);
      const double d = depth + variant.distance_change_m, grow = d / depth;
      const Eigen::Isometry3d in_camera =
          board_facing_camera(board, d, sx * plan.spread_x_m * grow, sy * plan.spread_y_m * grow,
                              k % 2 ? tilt : -0.8 * tilt, k % 3 == 0 ? tilt : -0.8 * tilt,
                              roll_step * (k % 4) - 1.5 * roll_step);
      tools.push_back(twin * in_camera * board_in_tool.inverse());
      ++k;
    }
  return tools;
}

int ReachablePlan::held() const { return static_cast<int>(std::count_if(variant.begin(), variant.end(), [](int v) { return v >= 0; })); }
int ReachablePlan::nominal() const { return static_cast<int>(std::count(variant.begin(), variant.end(), 0)); }

ReachablePlan choose_reachable(const std::function<std::vector<Eigen::Isometry3d>(const PoseVariant&)>& make,
                               const std::function<bool(const Eigen::Isometry3d&)>& reachable) {
  std::vector<std::vector<Eigen::Isometry3d>> plans{make(PoseVariant{})};
  for (const PoseVariant& v : fallback_variants()) plans.push_back(make(v));
  ReachablePlan out;
  for (std::size_t k = 0; k < plans[0].size(); ++k) {
    int chosen = -1;
    for (std::size_t v = 0; v < plans.size() && chosen < 0; ++v)
      if (reachable(plans[v][k])) chosen = static_cast<int>(v);
    out.poses.push_back(plans[std::max(chosen, 0)][k]);
    out.variant.push_back(chosen);
  }
  return out;
}

}  // namespace harvest::calib
