#include "sim/renderer.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <opencv2/imgcodecs.hpp>

#include "sim/cameras.hpp"
#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

// Thesis eq. 2-1 and the thresholds of its segmentation (Cr 22..90, Cg -25..25, Cb -220..-5).
bool thesis_orange(const cv::Vec3b& bgr) {
  const double b = bgr[0], g = bgr[1], r = bgr[2];
  const double cr = 0.721 * r - 0.587 * g - 0.114 * b;
  const double cg = -0.299 * r + 0.413 * g - 0.114 * b;
  const double cb = -0.299 * r - 0.587 * g + 0.886 * b;
  return cr >= 22 && cr <= 90 && cg >= -25 && cg <= 25 && cb >= -220 && cb <= -5;
}

struct Stats {
  int fruit = 0, fruit_orange = 0, other = 0, other_orange = 0;
  double u = 0, v = 0;
};

Stats classify(const Renderer& r, const cv::Mat& img) {
  Stats s;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const bool orange = thesis_orange(img.at<cv::Vec3b>(y, x));
      if (r.ids()[static_cast<std::size_t>(y * img.cols + x)] >= 0) {
        ++s.fruit;
        s.fruit_orange += orange;
        s.u += x;
        s.v += y;
      } else {
        ++s.other;
        s.other_orange += orange;
      }
    }
  if (s.fruit > 0) {
    s.u /= s.fruit;
    s.v /= s.fruit;
  }
  return s;
}

TEST(Renderer, FruitPassesTheThesisColourThresholdsAndNothingElseDoes) {
  Scenario sc = test::one_fruit();
  sc.canopy.leaves = 300;
  sc.canopy.region = {Vec3(-0.6, 1.1, -0.6), Vec3(0.6, 1.6, 0.6)};
  sc.canopy.branches = 2;
  sc.canopy.trunk_base = Vec3(0.3, 1.6, 0.0);
  sc.fixed_camera.noise_std = 2.0;
  const Scene scene(sc);
  Renderer r(sc.fixed_camera.model, sc.fixed_camera.noise_std, 1);
  const cv::Mat img = r.render(scene, sc.fixed_camera_truth).clone();
  const Stats s = classify(r, img);
  ASSERT_GT(s.fruit, 500);
  EXPECT_GE(s.fruit_orange, 0.98 * s.fruit);  // shaded side included
  EXPECT_LE(s.other_orange, 0.001 * s.other);  // sky, leaves, bark
  int leaf = 0;
  for (auto id : r.ids()) leaf += id == Renderer::kLeaf;
  EXPECT_GT(leaf, 1000);
}

TEST(Renderer, FruitCentreAndSizeMatchTheCameraModel) {
  const Vec3 centre(0.12, 0.9, 0.08);  // off axis, so distortion matters
  Scenario sc = test::one_fruit(centre, 0.075);
  const Scene scene(sc);
  Renderer r(sc.fixed_camera.model, 0.0, 1);
  const cv::Mat img = r.render(scene, sc.fixed_camera_truth).clone();
  const Stats s = classify(r, img);
  const Mat3& R = sc.fixed_camera_truth.rotation;
  const Vec3 p_cam = R.transpose() * (centre - sc.fixed_camera_truth.position);
  const Eigen::Vector2d px = sc.fixed_camera.model.project(p_cam);
  EXPECT_NEAR(s.u, px.x(), 0.5);
  EXPECT_NEAR(s.v, px.y(), 0.5);
  // Apparent area: the disc of the pinhole image (distortion changes it by a few %).
  const auto& m = sc.fixed_camera.model;
  const double area = M_PI * (m.fx * 0.0375 / p_cam.z()) * (m.fy * 0.0375 / p_cam.z());
  EXPECT_NEAR(s.fruit, area, 0.08 * area);
  EXPECT_EQ(r.visible_pixels()[0], s.fruit);
  EXPECT_EQ(r.silhouette_pixels()[0], s.fruit);
}

TEST(Renderer, LeafInFrontHidesTheFruit) {
  Scenario sc = test::one_fruit();
  Scene scene(sc);
  Renderer r(sc.fixed_camera.model, 0.0, 1);
  r.render(scene, sc.fixed_camera_truth);
  const int unoccluded = r.visible_pixels()[0];
  // A leaf across the line of sight, half way to the fruit.
  Scene leafy(sc);
  Leaf leaf;
  leaf.centre = Vec3(0.0, 0.5, 0.0);
  leaf.normal = Vec3::UnitY();
  leaf.u = Vec3::UnitX();
  leaf.v = Vec3::UnitZ();
  leaf.half_length = leaf.half_width = 0.04;
  leaf.albedo_rgb = Vec3(50, 100, 30);
  leafy.add_leaf(leaf);
  r.render(leafy, sc.fixed_camera_truth);
  EXPECT_EQ(r.silhouette_pixels()[0], unoccluded);
  EXPECT_LT(r.visible_pixels()[0], unoccluded);
  EXPECT_EQ(r.ids()[120 * 320 + 160], Renderer::kLeaf);
}

TEST(Renderer, PickedFruitIsNotDrawnAndCameraInsideFruitSeesItsWall) {
  Scenario sc = test::one_fruit();
  Scene scene(sc);
  Renderer r(sc.fixed_camera.model, 0.0, 1);
  Placement inside = sc.fixed_camera_truth;
  inside.position = Vec3(0.0, 1.0, 0.0);
  r.render(scene, inside);
  EXPECT_EQ(r.visible_pixels()[0], 320 * 240);
  scene.fruit()[0].state = FruitState::kPicked;
  r.render(scene, sc.fixed_camera_truth);
  EXPECT_EQ(r.visible_pixels()[0], 0);
}

TEST(Renderer, NoiseIsSeededAndChangesFromFrameToFrame) {
  Scenario sc = test::one_fruit();
  const Scene scene(sc);
  Renderer a(sc.fixed_camera.model, 3.0, 42), b(sc.fixed_camera.model, 3.0, 42);
  const cv::Mat a1 = a.render(scene, sc.fixed_camera_truth).clone();
  const cv::Mat b1 = b.render(scene, sc.fixed_camera_truth).clone();
  const cv::Mat a2 = a.render(scene, sc.fixed_camera_truth).clone();
  EXPECT_EQ(cv::norm(a1, b1, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(a1, a2, cv::NORM_L1), 0.0);
}

TEST(Renderer, PublishesImagesAsTheCameraDriverDoes) {
  Scenario sc = test::one_fruit();
  const Scene scene(sc);
  Renderer r(sc.fixed_camera.model, 0.0, 1);
  const cv::Mat& img = r.render(scene, sc.fixed_camera_truth);
  const image_t raw = SimCameras::make_image(img, "bgr8", 90);
  EXPECT_EQ(raw.encoding, +image_t::ENCODING_BGR8);
  EXPECT_EQ(raw.stride, 320 * 3);
  EXPECT_EQ(raw.size, 320 * 240 * 3);
  EXPECT_EQ(raw.sensor_width, 320);
  EXPECT_FLOAT_EQ(raw.roi_px[2], 320.0f);
  const image_t jpeg = SimCameras::make_image(img, "jpeg", 90);
  EXPECT_EQ(jpeg.encoding, +image_t::ENCODING_JPEG);
  const cv::Mat decoded = cv::imdecode(jpeg.data, cv::IMREAD_COLOR);
  ASSERT_EQ(decoded.cols, 320);
  EXPECT_LT(cv::norm(decoded, img, cv::NORM_L1) / (320.0 * 240 * 3), 3.0);
}

// Set HARVEST_SIM_DUMP=DIR to write the first frame of every shipped scenario.
TEST(Renderer, DumpScenarioFramesOnRequest) {
  const char* dir = std::getenv("HARVEST_SIM_DUMP");
  if (dir == nullptr) GTEST_SKIP() << "set HARVEST_SIM_DUMP=DIR to write frames";
  for (const auto& e : std::filesystem::directory_iterator("config/scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    for (const char* style : {"flat", "field"}) {
      Scenario sc = load_scenario(e.path().string());
      sc.look.style = style;
      const Scene scene(sc);
      const std::string stem = std::string(dir) + "/" + e.path().stem().string() + "_" + style;
      Renderer fixed(sc.fixed_camera.model, sc.fixed_camera.noise_std, 1);
      fixed.set_look(sc.look, sc.fixed_camera.rate_hz);
      cv::imwrite(stem + "_fixed.png", fixed.render(scene, sc.fixed_camera_truth));
      Renderer hand(sc.hand_camera.model, sc.hand_camera.noise_std, 2);
      hand.set_look(sc.look, sc.hand_camera.rate_hz);
      const Placement start{look_at_rotation(sc.arm.start_tool_position, sc.arm.start_look_at),
                            sc.arm.start_tool_position};
      cv::imwrite(stem + "_hand.png", hand.render(scene, start));
      // Near the first fruit, moving towards it at 0.3 m/s.
      const Vec3 fruit = scene.fruit().front().position;
      const Vec3 axis = (fruit - sc.arm.start_tool_position).normalized();
      const Vec3 near = fruit - 0.2 * axis;
      const Vec3 before = near - 0.01 * axis;
      cv::imwrite(stem + "_hand_near.png", hand.render(scene, {look_at_rotation(near, fruit), near},
                                                       {look_at_rotation(before, fruit), before}));
    }
  }
}

}  // namespace
}  // namespace harvest::sim
