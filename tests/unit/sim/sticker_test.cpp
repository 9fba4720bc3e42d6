// Teach by zooming in the simulator (issue 17): a printed sticker on a fruit,
// drawn by every camera, and CAMERA_FIXED_ZOOM, the fixed camera zoomed on it.
#include "sim/sticker.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "harvest/image_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "sim/sim_node.hpp"
#include "test_scenes.hpp"
#include "test_support.hpp"

namespace harvest::sim {
namespace {

constexpr double kSticker = 0.04;

// Shi-Tomasi corners inside the box (what the feature tracker would find there).
int corners_in(const cv::Mat& bgr, const cv::Rect& box) {
  cv::Mat gray;
  cv::cvtColor(bgr(box), gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point2f> c;
  cv::goodFeaturesToTrack(gray, c, 500, 0.05, 3);
  return static_cast<int>(c.size());
}

// Pixels of the last render where the sticker is the nearest surface.
int sticker_pixels(const Renderer& r) {
  return static_cast<int>(std::count(r.ids().begin(), r.ids().end(), Renderer::kExtra));
}

TEST(Sticker, ScenarioKeys) {
  const auto doc = config::Document::load_string(
      "name: t\nfruit:\n  - {position_mm: [0, 1000, 0], diameter_mm: 70, sticker_mm: 40}\n"
      "  - {position_mm: [0, 1000, 200]}\nzoom: {fruit: 0, distance_mm: 250, rate_hz: 2}\n");
  const Scenario s = Scenario::from_config(doc.root());
  doc.check_unused();
  EXPECT_NEAR(s.fruit[0].sticker, 0.04, 1e-12);
  EXPECT_EQ(s.fruit[1].sticker, 0.0);
  EXPECT_TRUE(s.zoom.enabled());
  EXPECT_EQ(s.zoom.fruit, 0);
  EXPECT_NEAR(s.zoom.distance, 0.25, 1e-12);
  EXPECT_NEAR(s.zoom.rate_hz, 2.0, 1e-12);
  const auto none = config::Document::load_string("name: t\n");
  EXPECT_FALSE(Scenario::from_config(none.root()).zoom.enabled());
  const auto bad =
      config::Document::load_string("name: t\nfruit:\n  - {position_mm: [0, 1000, 0]}\nzoom: {fruit: 1}\n");
  EXPECT_THROW(Scenario::from_config(bad.root()), config::Error);
  // A run whose variant leaves the zoomed fruit out has no zoom; one that keeps it follows it.
  Scenario v = s;
  v.variants = {{Vec3(0, 0.5, 0), Vec3(0, 1, 0), {1}}, {Vec3(0, 0.5, 0), Vec3(0, 1, 0), {1, 0}}};
  EXPECT_FALSE(v.for_run(0).zoom.enabled());
  EXPECT_EQ(v.for_run(1).zoom.fruit, 1);
}

TEST(Sticker, DrawnInBothCamerasRichInCornersAndSeeded) {
  Scenario s = test::one_fruit(Vec3(0.0, 1.0, 0.0), 0.07);
  const Scene scene(s);
  Renderer plain(s.fixed_camera.model, 0.0, 1), with(s.fixed_camera.model, 0.0, 1);
  auto sticker = std::make_shared<const StickerPrimitive>(scene, 0, kSticker, s.fixed_camera_truth.position, 7);
  with.add_primitive(sticker);
  // Fixed camera, 1 m away: the fruit is a ~29 px disc; the sticker its middle.
  const cv::Rect fruit_box(160 - 20, 120 - 20, 40, 40);
  const cv::Mat a = plain.render(scene, s.fixed_camera_truth).clone();
  const cv::Mat b = with.render(scene, s.fixed_camera_truth).clone();
  const int fixed_px = sticker_pixels(with);
  // Camera-in-hand 0.25 m in front of the fruit, 10 degrees off the sticker's normal: ~64 px sticker.
  const Vec3 eye = Vec3(0.0, 1.0, 0.0) + 0.25 * Vec3(0.0, -std::cos(0.1745), std::sin(0.1745));
  const Placement hand{look_at_rotation(eye, Vec3(0.0, 1.0, 0.0)), eye};
  const cv::Mat c = plain.render(scene, hand).clone();
  const cv::Mat d = with.render(scene, hand).clone();
  const int hand_px = sticker_pixels(with);
  const cv::Rect hand_box(160 - 50, 120 - 50, 100, 100);
  const int fixed_plain = corners_in(a, fruit_box), fixed_with = corners_in(b, fruit_box);
  const int hand_plain = corners_in(c, hand_box), hand_with = corners_in(d, hand_box);
  std::printf("sticker pixels: fixed %d, hand %d; corners plain/with sticker: fixed %d/%d, hand %d/%d\n", fixed_px,
              hand_px, fixed_plain, fixed_with, hand_plain, hand_with);
  // Its area: (0.04 m * 416.8 px/m / 0.965)^2 ~ 300 px at 1 m, ~4400 px at 0.25 m (a little foreshortened).
  EXPECT_GT(fixed_px, 200);
  EXPECT_LT(fixed_px, 400);
  EXPECT_GT(hand_px, 3000);
  EXPECT_LT(hand_px, 6000);
  EXPECT_GE(hand_with, 3 * hand_plain);  // a smooth shaded orange: little to track but its outline
  EXPECT_GE(hand_with, 40);
  EXPECT_GT(fixed_with, fixed_plain);

  // The print is the seed's.
  EXPECT_EQ(cv::norm(sticker_print(128, 7), sticker_print(128, 7), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(sticker_print(128, 7), sticker_print(128, 8), cv::NORM_L1), 1e5);
  // It faces the fixed camera and follows the fruit.
  EXPECT_LT((sticker->normal() - Vec3(0, -1, 0)).norm(), 1e-12);
  Scene moved = scene;
  StickerPrimitive on_moved(moved, 0, kSticker, s.fixed_camera_truth.position, 7);
  moved.fruit()[0].position += Vec3(0.01, 0, 0);
  EXPECT_LT((on_moved.centre() - Vec3(0.01, 1.0 - 0.035 - 0.0005, 0)).norm(), 1e-9);
}

// Runs the simulator for `seconds` of log time; returns its output records.
std::vector<rt::LogRecord> run_sim(const Scenario& scenario, double seconds) {
  harvest::testing::TempDir dir;
  constexpr rt::Micros kT0 = 1'700'000'000'000'000;
  rt::write_log(dir / "in.lcm", {{kT0, "UNRELATED", std::vector<uint8_t>{0}}});
  rt::ReplayOptions o;
  o.input_log = dir / "in.lcm";
  o.output_log = dir / "out.lcm";
  o.tail = rt::from_seconds(seconds);
  SimConfig config;
  config.stop_when_done = false;
  config.render_thread = false;  // logical time: frames rendered on the loop
  SimNode node(config, scenario);
  rt::ReplayRunner runner(o);
  runner.add(node);
  runner.run();
  return rt::read_log(dir / "out.lcm");
}

TEST(Sticker, ZoomedCameraLooksAtTheFruitAsTheHandCameraFromTheZoomDistance) {
  Scenario s = test::one_fruit(Vec3(0.05, 1.0, -0.08), 0.07);  // off the fixed camera's axis: the zoom turns to it
  s.fruit[0].sticker = kSticker;
  s.hand_camera.encoding = "bgr8";
  s.zoom.fruit = 0;
  s.zoom.distance = 0.2;
  s.zoom.rate_hz = 2.0;
  int zoomed = 0;
  cv::Mat last;
  image_t last_msg;
  for (const auto& r : run_sim(s, 1.2)) {
    if (r.channel != channels::kCameraFixedZoom) continue;
    ++zoomed;
    last_msg = *rt::decode<image_t>(r.data);
    last = camera::decode_image(last_msg).bgr;
  }
  EXPECT_GE(zoomed, 2);
  EXPECT_LE(zoomed, 3);
  ASSERT_FALSE(last.empty());
  EXPECT_EQ(last.cols, 320);
  EXPECT_EQ(last_msg.header.frame_id, "camera_fixed_zoom");
  EXPECT_EQ(last_msg.sensor_width, s.hand_camera.sensor_width);  // binned as the hand camera's frames
  // The fruit (orange or sticker, not sky) along the middle row and column: centred, its sticker (on the line
  // from the fixed camera to the fruit centre) scaled as from 0.2 m: the zoomed focal length is
  // fx * (distance to the sticker) / 0.2, and the fruit's outline, its centre c farther back, spans
  // 2 f_zoom r / sqrt(|c|^2 - r^2).
  auto fruit_px = [&](int x, int y) {
    const cv::Vec3b p = last.at<cv::Vec3b>(y, x);  // BGR
    return p[2] > p[0] + 30;                       // sky is blue
  };
  int x0 = -1, x1 = -1, y0 = -1, y1 = -1;
  for (int x = 0; x < last.cols; ++x)
    if (fruit_px(x, 120)) (x0 < 0 ? x0 : x1) = x;
  for (int y = 0; y < last.rows; ++y)
    if (fruit_px(160, y)) (y0 < 0 ? y0 : y1) = y;
  const double c = s.fruit[0].position.norm(), r = 0.035, zoom = (c - r - 0.0005) / 0.2;
  const double expect_w = 2 * zoom * s.hand_camera.model.fx * r / std::sqrt(c * c - r * r);
  const double expect_h = 2 * zoom * s.hand_camera.model.fy * r / std::sqrt(c * c - r * r);
  std::printf("zoomed fruit: x %d..%d (%.1f px expected wide), y %d..%d (%.1f expected)\n", x0, x1, expect_w, y0, y1,
              expect_h);
  EXPECT_NEAR(x1 - x0 + 1, expect_w, 0.02 * expect_w);
  EXPECT_NEAR(y1 - y0 + 1, expect_h, 0.02 * expect_h);
  EXPECT_NEAR(0.5 * (x0 + x1), 159.5, 3.0);
  EXPECT_NEAR(0.5 * (y0 + y1), 119.5, 3.0);
  EXPECT_GE(corners_in(last, cv::Rect(110, 70, 100, 100)), 40);

  // Without a zoom in the scenario: no CAMERA_FIXED_ZOOM.
  s.zoom.fruit = -1;
  for (const auto& r : run_sim(s, 0.5)) EXPECT_NE(r.channel, channels::kCameraFixedZoom);
}

}  // namespace
}  // namespace harvest::sim
