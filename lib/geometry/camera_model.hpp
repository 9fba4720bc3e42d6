// Pinhole camera with skew and OpenCV's five-coefficient lens distortion.
//
// Pixel p = A * d(m): m = (X/Z, Y/Z) are the normalised coordinates of a
// camera-frame point (OpenCV optical frame: x right, y down, z forward), d()
// applies radial (k1, k2, k3) and tangential (p1, p2) distortion, and A is the
// intrinsic matrix of thesis eq. 5-9 / 6-9:
//
//   A = [[l1, -l1 cot(phi), u0], [0, l2 / sin(phi), v0], [0, 0, 1]]
//     = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]].
//
// The inverse of the distortion has no closed form; undistort_to_normalized()
// uses the fixed-point iteration of thesis appendix D (also OpenCV's). The
// simulator renders with this same model, so software and simulated cameras
// agree on every convention (pixel centres at integer coordinates).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <string>

#include "config/config.hpp"

namespace harvest::geometry {

struct CameraModel {
  double fx = 1.0;               // A(0,0) [px]
  double fy = 1.0;               // A(1,1) [px]
  double skew = 0.0;             // A(0,1) [px]
  double cx = 0.0;               // A(0,2) [px]
  double cy = 0.0;               // A(1,2) [px]
  std::array<double, 5> dist{};  // k1 k2 p1 p2 k3 (OpenCV order)
  int width = 0;                 // [px]
  int height = 0;                // [px]

  // Reads an OpenCV calibration file (cv::FileStorage YAML/XML/JSON) with
  // camera_matrix (3x3), distortion_coefficients (4 or 5 values, k3 = 0 if 4),
  // image_width and image_height. Throws std::runtime_error naming the file and
  // the problem.
  static CameraModel load(const std::filesystem::path& file);
  // load() of the file named by config key `key` (relative to the config
  // file, `fallback` if absent): the one way every process reads a
  // calibration, so a file loads the same in each. A bad file fails as a
  // config::Error naming the key, the file and the problem.
  static CameraModel from_config(const config::Node& n, const config::Key<config::Path>& key);
  // The same with a default derived from other keys (`key.derived` says how).
  static CameraModel from_config(const config::Node& n, const config::Key<config::Path>& key,
                                 const std::string& derived_fallback);
  // Writes the same format (round-trips through load()).
  void save(const std::filesystem::path& file) const;

  // From the thesis parameters of eq. 5-9: l1, l2 [px], skew angle phi [rad]
  // (pi/2 = no skew), principal point (u0, v0) [px].
  static CameraModel from_thesis(double l1, double l2, double phi, double u0, double v0, int width, int height,
                                 const std::array<double, 5>& dist = {});

  // Throws std::invalid_argument if the parameters cannot describe a camera.
  void validate() const;

  Eigen::Matrix3d matrix() const;

  // Distortion applied to / removed from normalised coordinates.
  Eigen::Vector2d distort(const Eigen::Vector2d& m) const;
  Eigen::Vector2d undistort(const Eigen::Vector2d& md, int iterations = 20) const;

  // Camera-frame point (z > 0) -> distorted pixel.
  Eigen::Vector2d project(const Eigen::Vector3d& p_cam) const;
  // Normalised (undistorted) coordinates -> distorted pixel.
  Eigen::Vector2d normalized_to_pixel(const Eigen::Vector2d& m) const;
  // Distorted pixel -> undistorted normalised coordinates (x/z, y/z).
  Eigen::Vector2d undistort_to_normalized(const Eigen::Vector2d& px, int iterations = 20) const;
  // Distorted pixel and depth along the optical axis -> camera-frame point (eq. 6-12).
  Eigen::Vector3d back_project(const Eigen::Vector2d& px, double depth) const;

  // The same camera seen through a region of interest (x, y, w, h in this
  // camera's pixels) rescaled to out_width x out_height: digital zoom.
  CameraModel zoomed(double roi_x, double roi_y, double roi_w, double roi_h, int out_width, int out_height) const;

  bool has_distortion() const;
};

}  // namespace harvest::geometry
