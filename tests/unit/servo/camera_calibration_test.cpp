// Every process reads a camera calibration through geometry::CameraModel::from_config,
// so one file gives one camera everywhere: a 4-coefficient file (k3 omitted, as
// OpenCV writes for a calibration without CALIB_RATIONAL/k3) loads in the
// controller exactly as in the detector and the reconstructor.
#include <gtest/gtest.h>

#include <fstream>

#include "servo/servo_config.hpp"
#include "test_support.hpp"
#include "vision/detector_node.hpp"
#include "vision/reconstructor.hpp"

namespace harvest {
namespace {

void write_calibration(const std::filesystem::path& file, const std::string& coefficients, int count) {
  std::ofstream out(file);
  out << "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n"
         "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
         "   data: [ 830.5, 0., 321.5, 0., 765.25, 238.5, 0., 0., 1. ]\n"
         "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: "
      << count << "\n   dt: d\n   data: [ " << coefficients << " ]\n";
}

void expect_same(const geometry::CameraModel& a, const geometry::CameraModel& b) {
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.skew, b.skew);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
  EXPECT_EQ(a.dist, b.dist);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
}

TEST(CameraCalibration, AFourCoefficientFileLoadsTheSameEverywhere) {
  harvest::testing::TempDir dir;
  const auto file = dir.path() / "hand4.yaml";
  write_calibration(file, "-0.08, 0.02, 0.001, -0.0005", 4);
  const std::string f = file.string();

  const auto direct = geometry::CameraModel::load(file);
  EXPECT_EQ(direct.dist, (std::array<double, 5>{-0.08, 0.02, 0.001, -0.0005, 0.0}));
  EXPECT_EQ(direct.fx, 830.5);

  const auto servo =
      servo::ServoConfig::from_yaml(config::Document::load_string("hand_camera_calibration: " + f).root());
  const auto detector =
      vision::DetectorNodeConfig::from_yaml(config::Document::load_string("camera: hand\ncalibration: " + f).root());
  const auto reconstructor = vision::ReconstructorConfig::from_yaml(
      config::Document::load_string("camera_hand: {calibration: " + f + "}").root());
  expect_same(servo.hand_camera, direct);
  expect_same(detector.calibration, direct);
  expect_same(reconstructor.hand_camera, direct);
}

// A file no loader accepts fails in every one, naming the key and the count.
TEST(CameraCalibration, AThreeCoefficientFileIsRefusedEverywhere) {
  harvest::testing::TempDir dir;
  const auto file = dir.path() / "hand3.yaml";
  write_calibration(file, "-0.08, 0.02, 0.001", 3);
  const std::string f = file.string();
  const auto refused = [](auto load, const std::string& key) {
    try {
      load();
      ADD_FAILURE() << key << ": a 3-coefficient calibration was accepted";
    } catch (const config::Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("4 or 5 values"), std::string::npos) << e.what();
    }
  };
  refused([&] { servo::ServoConfig::from_yaml(config::Document::load_string("hand_camera_calibration: " + f).root()); },
          "hand_camera_calibration");
  refused([&] { vision::DetectorNodeConfig::from_yaml(config::Document::load_string("calibration: " + f).root()); },
          "calibration");
  refused(
      [&] {
        vision::ReconstructorConfig::from_yaml(
            config::Document::load_string("camera_hand: {calibration: " + f + "}").root());
      },
      "camera_hand.calibration");
}

}  // namespace
}  // namespace harvest
