#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/calib3d.hpp>

#include "geometry/camera_model.hpp"
#include "test_support.hpp"

namespace harvest::geometry {
namespace {

CameraModel distorted_camera() {
  CameraModel c;
  c.fx = 833.57;
  c.fy = 767.02;
  c.cx = 322.4;
  c.cy = 236.1;
  c.dist = {-0.21, 0.09, 0.0012, -0.0007, -0.015};
  c.width = 640;
  c.height = 480;
  return c;
}

std::vector<cv::Point3d> grid_points() {
  std::vector<cv::Point3d> pts;
  for (double x = -0.3; x <= 0.3; x += 0.05)
    for (double y = -0.22; y <= 0.22; y += 0.055) pts.emplace_back(x, y, 0.8 + 0.3 * x);
  return pts;
}

TEST(CameraModel, ProjectMatchesOpenCV) {
  const CameraModel c = distorted_camera();
  const auto pts = grid_points();
  std::vector<cv::Point2d> expected;
  const cv::Matx33d k(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, c.dist, expected);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector2d px = c.project({pts[i].x, pts[i].y, pts[i].z});
    EXPECT_NEAR(px.x(), expected[i].x, 1e-9);
    EXPECT_NEAR(px.y(), expected[i].y, 1e-9);
  }
}

TEST(CameraModel, UndistortMatchesOpenCV) {
  const CameraModel c = distorted_camera();
  std::vector<cv::Point2d> pixels;
  for (int u = 0; u < c.width; u += 40)
    for (int v = 0; v < c.height; v += 40) pixels.emplace_back(u + 0.25, v + 0.75);
  std::vector<cv::Point2d> expected;
  const cv::Matx33d k(c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  cv::undistortPoints(pixels, expected, k, c.dist, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0));
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector2d m = c.undistort_to_normalized({pixels[i].x, pixels[i].y});
    EXPECT_NEAR(m.x(), expected[i].x, 1e-12);
    EXPECT_NEAR(m.y(), expected[i].y, 1e-12);
  }
}

TEST(CameraModel, UndistortInvertsProjectionInsideTheImage) {
  const CameraModel c = distorted_camera();
  for (const auto& p : grid_points()) {
    const Eigen::Vector2d px = c.project({p.x, p.y, p.z});
    const Eigen::Vector2d m = c.undistort_to_normalized(px);
    // 20 iterations of appendix D: well below a hundredth of a pixel at the corners.
    EXPECT_NEAR(m.x() * c.fx, p.x / p.z * c.fx, 1e-3);
    EXPECT_NEAR(m.y() * c.fy, p.y / p.z * c.fy, 1e-3);
  }
}

TEST(CameraModel, ThesisSkewParameters) {
  // Section 5.6.2: l1 = l2 = 147, phi = 1.53 rad, u0 = v0 = 120.
  const CameraModel c = CameraModel::from_thesis(147, 147, 1.53, 120, 120, 240, 240);
  EXPECT_NEAR(c.fx, 147, 1e-12);
  EXPECT_NEAR(c.skew, -6.000389, 1e-6);  // -147 cot(1.53)
  EXPECT_NEAR(c.fy, 147.122414, 1e-6);   // 147 / sin(1.53)
  // Hand-worked: point (0.1, 0.2, 1): u = 147*0.1 - 6.000389*0.2 + 120, v = 147.122414*0.2 + 120.
  const Eigen::Vector2d px = c.project({0.1, 0.2, 1.0});
  EXPECT_NEAR(px.x(), 133.499922, 1e-6);
  EXPECT_NEAR(px.y(), 149.424483, 1e-6);
  const Eigen::Vector2d m = c.undistort_to_normalized(px);
  EXPECT_NEAR(m.x(), 0.1, 1e-12);
  EXPECT_NEAR(m.y(), 0.2, 1e-12);
}

TEST(CameraModel, SkewWithDistortionRoundTrips) {
  CameraModel c = distorted_camera();
  c.skew = -4.5;
  const Eigen::Vector3d p(0.12, -0.07, 0.9);
  const Eigen::Vector3d back = c.back_project(c.project(p), 0.9);
  EXPECT_NEAR((back - p).norm(), 0.0, 1e-9);
}

TEST(CameraModel, LoadsShippedCalibrations) {
  for (const char* name : {"config/cameras/fixed.yaml", "config/cameras/hand.yaml"}) {
    const CameraModel c = CameraModel::load(name);
    EXPECT_EQ(c.width, 640) << name;
    EXPECT_EQ(c.height, 480) << name;
    EXPECT_DOUBLE_EQ(c.fx, 833.57) << name;
    EXPECT_DOUBLE_EQ(c.fy, 767.02) << name;
  }
}

TEST(CameraModel, SaveLoadRoundTrip) {
  testing::TempDir dir;
  CameraModel c = distorted_camera();
  c.skew = 1.25;
  c.save(dir / "cam.yaml");
  const CameraModel back = CameraModel::load(dir / "cam.yaml");
  EXPECT_EQ(back.matrix(), c.matrix());
  EXPECT_EQ(back.dist, c.dist);
  EXPECT_EQ(back.width, c.width);
}

void write(const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; }

TEST(CameraModel, BadFilesGiveErrorsNamingTheFile) {
  testing::TempDir dir;
  auto expect_error = [](const std::filesystem::path& p, const std::string& fragment) {
    try {
      CameraModel::load(p);
      ADD_FAILURE() << "no error for " << p;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_error(dir / "missing.yaml", "no such file");
  write(dir / "garbage.yaml", "%YAML:1.0\n---\ncamera_matrix: [1, 2\n");
  expect_error(dir / "garbage.yaml", "");
  const std::string matrix =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 800., 0., 320., 0., 800., 240., "
      "0., 0., 1. ]\n";
  write(dir / "nodist.yaml", "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n" + matrix);
  expect_error(dir / "nodist.yaml", "distortion_coefficients");
  write(dir / "sixdist.yaml", "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n" + matrix +
                                  "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 6\n   dt: d\n"
                                  "   data: [ 0., 0., 0., 0., 0., 0. ]\n");
  expect_error(dir / "sixdist.yaml", "4 or 5");
  write(dir / "nosize.yaml", "%YAML:1.0\n---\n" + matrix +
                                 "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n"
                                 "   data: [ 0., 0., 0., 0. ]\n");
  expect_error(dir / "nosize.yaml", "image_width");
}

TEST(CameraModel, ZoomMapsPixelsLikeResize) {
  const CameraModel c = distorted_camera();
  // 2x digital zoom on the central quarter.
  const CameraModel z = c.zoomed(160, 120, 320, 240, 640, 480);
  const Eigen::Vector3d p(0.03, -0.02, 0.7);
  const Eigen::Vector2d full = c.project(p), zoom = z.project(p);
  EXPECT_NEAR(zoom.x(), (full.x() + 0.5 - 160) * 2 - 0.5, 1e-9);
  EXPECT_NEAR(zoom.y(), (full.y() + 0.5 - 120) * 2 - 0.5, 1e-9);
}

}  // namespace
}  // namespace harvest::geometry
