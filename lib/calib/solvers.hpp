// The calibration solvers: view checks, OpenCV's solvers, and what their
// answers are worth (residuals, standard deviations, coverage, spread).
// OpenCV does the estimation (cv::calibrateCamera, cv::calibrateHandEye,
// cv::calibrateRobotWorldHandEye); this file chooses the inputs, refuses
// datasets that cannot determine the answer, and reports.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/views.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::calib {

// A dataset that cannot give a trustworthy answer; what() says why and what to do.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One corner's reprojection: where it was found, and found minus reprojected [px].
struct Residual {
  cv::Point2f pixel;
  cv::Point2f error;
};

struct ViewResult {
  int64_t utime = 0;
  double rms_px = 0.0;
  std::vector<Residual> residuals;
  // Arm-moved procedures: how far this view's estimate of the fixed object
  // (the board on its stand, or the camera on the base) is from the mean.
  double position_error_m = 0.0, rotation_error_rad = 0.0;
};

struct IntrinsicsOptions {
  int min_views = 8;
  double min_tilt_spread_rad = 15.0 * M_PI / 180.0;  // board orientations must differ by this much
  double max_focal_std = 0.01;                       // relative standard deviation of fx, fy
  int min_corners_per_region = 4;                    // 3 x 3 image regions with fewer lack coverage
};

struct IntrinsicsResult {
  geometry::CameraModel model;
  double rms_px = 0.0;
  // Standard deviations of fx, fy, cx, cy, k1, k2, p1, p2, k3 (cv::calibrateCamera's
  // stdDeviationsIntrinsics; same units as the parameters).
  std::array<double, 9> std_dev{};
  std::vector<ViewResult> views;
  std::vector<std::string> uncovered;  // 3 x 3 image regions lacking corners ("top left", ...)
  int corners = 0;
  bool mirrored = false;
  double tilt_spread_rad = 0.0;
};

// Throws CalibrationError on too few views, views that cannot separate focal
// length from distance, or an answer less certain than the options allow.
IntrinsicsResult solve_intrinsics(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const IntrinsicsOptions& options = {});

// The camera as seen through a left-right flipped image (cx -> w - 1 - cx,
// p2 -> -p2): how an improper camera frame is calibrated and posed.
geometry::CameraModel mirror_model(const geometry::CameraModel& m);

// Board pose in the camera (cv::solvePnP, iterative, on the proper image);
// for a mirrored view the result is the pose in the mirrored camera frame.
Eigen::Isometry3d board_in_camera(const BoardView& v, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const geometry::CameraModel& camera, ViewResult* result = nullptr);

struct MethodResult {
  std::string name;
  Eigen::Isometry3d transform;
};

struct PoseOptions {
  int min_views = 6;
  // The tool's rotations between views must turn about axes at least this far apart.
  double min_axis_spread_rad = 10.0 * M_PI / 180.0;
  double min_rotation_rad = 10.0 * M_PI / 180.0;  // largest rotation between two views
};

struct HandEyeResult {
  Eigen::Isometry3d camera_in_tool;         // p_tool = T p_camera (Park's answer)
  std::vector<MethodResult> methods;        // Tsai, Park, Daniilidis
  double spread_m = 0.0, spread_rad = 0.0;  // largest distance of a method's answer from Park's
  std::vector<ViewResult> views;            // position_error / rotation_error: the board in the base frame per view
  double rms_px = 0.0;                      // reprojection of the board corners through the tool poses and the answer
};

// Camera-in-hand pose on the tool from views of a fixed board with tool poses.
HandEyeResult solve_hand_eye(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                             const geometry::CameraModel& camera, const PoseOptions& options = {});

struct ExtrinsicsResult {
  Eigen::Isometry3d camera_in_base;  // p_base = T p_camera (improper when the views are mirrored)
  Eigen::Isometry3d board_in_tool;
  std::vector<MethodResult> methods;  // Shah, Li (camera in base)
  double spread_m = 0.0, spread_rad = 0.0;
  std::vector<ViewResult> views;  // position_error / rotation_error: the camera in the base frame per view
  double rms_px = 0.0;
  bool mirrored = false;
};

// Fixed camera in the base frame from views of a board carried by the tool
// (cv::calibrateRobotWorldHandEye).
ExtrinsicsResult solve_extrinsics(const std::vector<BoardView>& views, const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const geometry::CameraModel& camera, const PoseOptions& options = {});

// Checks that tool rotations between views turn about more than one axis and
// far enough; throws CalibrationError otherwise.
void check_rotation_diversity(const std::vector<Eigen::Isometry3d>& poses, const PoseOptions& options);

// Worst distance over the image between where two models undistort the same
// pixel, each through its own matrix (u = K m): the distortion error alone.
double worst_undistortion_difference(const geometry::CameraModel& a, const geometry::CameraModel& b, int step = 4);

}  // namespace harvest::calib
