// The perception chain as separate processes over real LCM: harvest-camera
// (a folder of rendered frames, digitally zoomed) -> harvest-fruit-detector
// -> harvest-reconstructor, with the shipped configurations. The fruit must
// come out where it was rendered, in the robot base frame.
#include <gtest/gtest.h>

#include <fstream>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/targets_t.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../../unit/vision/synthetic_scene.hpp"
#include "bus.hpp"
#include "geometry/camera_model.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace harvest::vision {
namespace {

TEST(PerceptionChain, RenderedFruitComesOutAtItsPlaceInTheBaseFrame) {
  // The world's camera is the software's calibration (config/cameras/fixed.yaml).
  const geometry::CameraModel cam = geometry::CameraModel::load(ht::source_path("config/cameras/fixed.yaml"));
  const double diameter = 0.0725;  // the statistical diameter of config/vision: depth is unbiased
  const Eigen::Vector3d fruit_cam(0.03, -0.02, 0.75);
  Eigen::Matrix3d r_fixed;  // config/vision/reconstructor.yaml (eq. 4-1)
  r_fixed << 0, 1, 0, 0, 0, 1, -1, 0, 0;
  const Eigen::Vector3d fruit_base = r_fixed * fruit_cam + Eigen::Vector3d(-0.254, 0.19685, -0.381);

  ht::TempDir dir;
  std::filesystem::create_directory(dir / "frames");
  cv::Mat3b img = test::background(640, 480);
  test::render_sphere(img, cam, fruit_cam, diameter / 2);
  ASSERT_TRUE(cv::imwrite((dir / "frames" / "0000.png").string(), img));
  // Zoom 2x on the centre of the sensor: the detector must map back to sensor pixels.
  std::ofstream(dir / "camera.yaml") << "camera: fixed\nsource: folder\npath: frames\nloop: true\n"
                                     << "frame_rate_hz: 10\nencoding: jpeg\njpeg_quality: 95\n"
                                     << "zoom_roi_px: [160, 120, 320, 240]\noutput_width: 640\noutput_height: 480\n";

  const std::string url = ht::unique_lcm_url();
  test::Bus bus(url);
  auto start = [&](const std::string& bin, const std::string& config, const std::string& log) {
    return std::make_unique<ht::ChildProcess>(
        std::vector<std::string>{ht::bin(bin), "--config", config, "--lcm-url", url, "--no-netcheck"}, dir / log);
  };
  auto reconstructor =
      start("harvest-reconstructor", ht::source_path("config/vision/reconstructor.yaml"), "reconstructor.txt");
  auto detector = start("harvest-fruit-detector", ht::source_path("config/vision/detector-fixed.yaml"), "detector.txt");
  auto camera = start("harvest-camera", (dir / "camera.yaml").string(), "camera.txt");

  ASSERT_TRUE(ht::eventually([&] { return bus.count("TARGETS") >= 2; }, 15s))
      << camera->output() << detector->output() << reconstructor->output();
  const auto targets = bus.on<targets_t>("TARGETS");
  const auto frames = bus.on<image_t>("CAMERA_FIXED");
  const auto detections = bus.on<fruit_detections_t>("FRUIT_FIXED");
  const targets_t& t = targets.back();
  ASSERT_EQ(t.num_targets, 1);
  EXPECT_EQ(t.source_camera, "fixed");
  EXPECT_TRUE(t.targets[0].selected);
  // Causality: the targets carry the time of the frame they were made from.
  bool from_a_frame = false;
  for (const image_t& f : frames) from_a_frame = from_a_frame || f.header.utime == t.header.utime;
  EXPECT_TRUE(from_a_frame);
  ASSERT_FALSE(detections.empty());
  const fruit_t& f = detections.back().fruits.at(0);
  const Eigen::Vector2d px = cam.project(fruit_cam);
  EXPECT_NEAR(f.u_px, px.x(), 1.0);  // in sensor pixels, not zoomed ones
  EXPECT_NEAR(f.v_px, px.y(), 1.0);
  EXPECT_EQ(detections.back().image_width, 640);
  // Depth from size within 2 %, the base-frame position within 2 % of the range.
  EXPECT_NEAR(t.targets[0].depth_m, fruit_cam.z(), 0.02 * fruit_cam.z());
  EXPECT_LT((Eigen::Vector3d(t.targets[0].position_base) - fruit_base).norm(), 0.02 * fruit_cam.norm());
  for (auto* p : {camera.get(), detector.get(), reconstructor.get()}) EXPECT_EQ(p->stop(), 0) << p->output();
}

}  // namespace
}  // namespace harvest::vision
