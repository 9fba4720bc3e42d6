// Teach by zooming on the simulator's frames (docs/teach-by-zooming.md): the
// zoomed view and camera-in-hand frames of config/scenarios/tbz.yaml (a 40 mm
// sticker on the fruit) and tbz_natural.yaml (the same scene without it),
// rendered as the simulator publishes them, matched as the feature tracker
// does in `region: fruit` (keypoints in the fruit's box grown by 20 %). With
// matches allowed anywhere in the box, the natural fruit's outline and the
// leaves beside it verify a homography in some frames; on the fruit's face
// (face_fraction 0.7 of its radius) nothing verifies on the natural fruit,
// and the sticker verifies at home and near.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "features/matcher.hpp"
#include "sim/cameras.hpp"
#include "sim/scenario.hpp"
#include "sim/scene.hpp"

namespace f = harvest::features;
namespace sim = harvest::sim;

namespace {

cv::Mat1b gray(const harvest::image_t& image) {
  const auto d = harvest::camera::decode_image(image);
  EXPECT_TRUE(d.ok()) << d.error;
  cv::Mat1b g;
  cv::cvtColor(d.bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

struct Tally {
  int frames = 0, verified_anywhere = 0, verified_on_face = 0, fewest_on_face = 1 << 30, most_on_face = 0;
};

// `frames` hand frames (fresh noise each) from `camera`, matched against the zoomed view.
Tally match_from(const sim::Scenario& s, const sim::Scene& scene, sim::SimCameras& cams, const sim::Placement& camera,
                 int frames) {
  const sim::Fruit& fruit = scene.fruit().front();
  const int64_t t0 = 2'000'000;
  const cv::Mat1b desired = gray(cams.render({sim::CameraId::kZoom, t0, scene.fruit(), camera, {}}));
  f::DesiredImageMatcher anywhere({}), on_face({});
  anywhere.set_desired(desired);
  on_face.set_desired(desired);
  // The fruit's disc in the hand image (true intrinsics, the model is at the image size).
  const auto& model = s.hand_camera.model;
  const sim::Vec3 p = camera.rotation.transpose() * (fruit.position - camera.position);
  const Eigen::Vector2d c = model.project(p);
  const double r = model.fx * fruit.radius / std::sqrt(p.squaredNorm() - fruit.radius * fruit.radius);
  const cv::Rect box(cvFloor(c.x() - 1.4 * r), cvFloor(c.y() - 1.4 * r), cvCeil(2.8 * r), cvCeil(2.8 * r));
  const f::Disc face{cv::Point2f(static_cast<float>(c.x()), static_cast<float>(c.y())), static_cast<float>(0.7 * r)};
  Tally t;
  for (int k = 0; k < frames; ++k) {
    const cv::Mat1b current =
        gray(cams.render({sim::CameraId::kHand, t0 + 33'333 * (k + 1), scene.fruit(), camera, {}}));
    EXPECT_EQ(current.cols, model.width);
    anywhere.reset_tracking();  // each frame detected afresh, as after a frame that failed
    on_face.reset_tracking();
    const auto a = anywhere.match(current, box);
    const auto m = on_face.match(current, box, face);
    ++t.frames;
    t.verified_anywhere += a.ok();
    t.verified_on_face += m.ok();
    t.fewest_on_face = std::min(t.fewest_on_face, m.num_inliers);
    t.most_on_face = std::max(t.most_on_face, m.num_inliers);
    if (k == 0)
      std::printf("    fruit r %.1f px at (%.0f, %.0f); anywhere: %s; on the face: %s\n", r, c.x(), c.y(),
                  a.text.c_str(), m.text.c_str());
  }
  return t;
}

}  // namespace

TEST(TbzFruitFace, NaturalPeelNeverVerifiesTheStickerDoesAtHomeAndNear) {
  {  // The two scenarios differ in the sticker only (the comparison below means nothing otherwise).
    const sim::Scenario a = sim::load_scenario("config/scenarios/tbz.yaml");
    const sim::Scenario b = sim::load_scenario("config/scenarios/tbz_natural.yaml");
    ASSERT_EQ(a.fruit.size(), 1u);
    ASSERT_EQ(b.fruit.size(), 1u);
    EXPECT_GT(a.fruit[0].sticker, 0.0);
    EXPECT_EQ(b.fruit[0].sticker, 0.0);
    EXPECT_EQ(a.seed, b.seed);
    EXPECT_EQ(a.fruit[0].position, b.fruit[0].position);
    EXPECT_EQ(a.fruit[0].diameter, b.fruit[0].diameter);
    EXPECT_EQ(a.canopy.leaves, b.canopy.leaves);
    EXPECT_EQ(a.zoom.distance, b.zoom.distance);
    EXPECT_EQ(a.zoom.rate_hz, b.zoom.rate_hz);
    EXPECT_EQ(a.arm.start_tool_position, b.arm.start_tool_position);
    EXPECT_EQ(a.arm.start_look_at, b.arm.start_look_at);
  }
  for (const char* file : {"config/scenarios/tbz.yaml", "config/scenarios/tbz_natural.yaml"}) {
    const sim::Scenario s = sim::load_scenario(file);
    const bool sticker = s.fruit.front().sticker > 0;
    const sim::Scene scene(s);
    sim::SimCameras cams(s, scene);
    ASSERT_TRUE(cams.has_zoom());
    const sim::Vec3 fruit = scene.fruit().front().position;
    const sim::Placement tool{sim::look_at_rotation(s.arm.start_tool_position, s.arm.start_look_at),
                              s.arm.start_tool_position};
    const sim::Placement home = sim::compose(tool, s.arm.hand_eye);
    // Near: 0.25 m from the fruit on the fixed camera's line of sight (where the zoomed view is from).
    const sim::Vec3 eye = fruit + 0.25 * (s.fixed_camera_truth.position - fruit).normalized();
    const sim::Placement near{sim::look_at_rotation(eye, fruit), eye};
    struct Pose {
      const char* name;
      sim::Placement camera;
    };
    for (const Pose& pose : {Pose{"home", home}, Pose{"near", near}}) {
      std::printf("%s, %s (%.0f mm from the fruit centre):\n", file, pose.name,
                  (pose.camera.position - fruit).norm() * 1000);
      const Tally t = match_from(s, scene, cams, pose.camera, 6);
      std::printf("  verified anywhere in the box %d of %d frames, on the face %d of %d (inliers on the face %d..%d)\n",
                  t.verified_anywhere, t.frames, t.verified_on_face, t.frames, t.fewest_on_face, t.most_on_face);
      if (sticker) {
        EXPECT_EQ(t.verified_on_face, t.frames) << file << " " << pose.name;
        EXPECT_GE(t.fewest_on_face, 12) << file << " " << pose.name;
      } else {
        EXPECT_EQ(t.verified_on_face, 0) << file << " " << pose.name;
      }
    }
  }
}
