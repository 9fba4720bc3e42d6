// The field look (scenario look.style: field): same geometry as the flat
// look, and each of the things real canopy images have that it adds.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "sim/renderer.hpp"
#include "sim/scenario.hpp"
#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

Scenario field(Scenario s) {
  s.look.style = "field";
  return s;
}

Renderer make(const Scenario& s, uint64_t seed = 1) {
  Renderer r(s.fixed_camera.model, s.fixed_camera.noise_std, seed);
  r.set_look(s.look, s.fixed_camera.rate_hz);
  return r;
}

// A small canopy around one fruit 1 m in front of the camera.
Scenario canopy() {
  Scenario s = test::one_fruit();
  s.canopy.leaves = 300;
  s.canopy.region = {Vec3(-0.6, 1.1, -0.6), Vec3(0.6, 1.6, 0.6)};
  s.canopy.branches = 2;
  s.canopy.trunk_base = Vec3(0.3, 1.6, 0.0);
  return s;
}

// Mean BGR over the pixels where `which` is the nearest surface.
cv::Scalar mean_over(const Renderer& r, const cv::Mat& img, int32_t which) {
  cv::Mat1b m(img.size(), uchar(0));
  for (int i = 0; i < img.rows * img.cols; ++i)
    if (r.ids()[static_cast<std::size_t>(i)] == which) m(i / img.cols, i % img.cols) = 255;
  return cv::mean(img, m);
}

double luminance(const cv::Scalar& bgr) { return 0.114 * bgr[0] + 0.587 * bgr[1] + 0.299 * bgr[2]; }

double sharpness(const cv::Mat& img) {
  cv::Mat grey, lap;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  cv::Laplacian(grey, lap, CV_64F);
  cv::Scalar m, sd;
  cv::meanStdDev(lap, m, sd);
  return sd[0];
}

TEST(FieldLook, SameGeometryAsTheFlatLook) {
  const Scenario s = canopy();
  const Scene scene(s);
  Renderer flat(s.fixed_camera.model, 2.0, 1);
  flat.render(scene, s.fixed_camera_truth);
  Renderer f = make(field(s));
  f.render(scene, s.fixed_camera_truth);
  EXPECT_EQ(flat.ids(), f.ids());
  EXPECT_EQ(flat.visible_pixels(), f.visible_pixels());
  EXPECT_EQ(flat.silhouette_pixels(), f.silhouette_pixels());
}

TEST(FieldLook, SkyGapsInTheCanopyAreOverexposed) {
  const Scenario s = field(load_scenario("config/scenarios/tree.yaml"));
  const Scene scene(s);
  Renderer r = make(s);
  const cv::Mat img = r.render(scene, s.fixed_camera_truth).clone();
  int sky = 0, clipped = 0;
  for (int i = 0; i < img.rows * img.cols; ++i) {
    if (r.ids()[static_cast<std::size_t>(i)] != Renderer::kSky || i / img.cols > img.rows / 3) continue;
    const auto& p = img.at<cv::Vec3b>(i / img.cols, i % img.cols);
    ++sky;
    clipped += std::max({p[0], p[1], p[2]}) >= 250;
  }
  ASSERT_GT(sky, 500);
  EXPECT_GT(clipped, 0.9 * sky);
}

TEST(FieldLook, PeelHasHighlightsAndTexture) {
  Scenario s = test::one_fruit(Vec3(0.0, 0.4, 0.0));
  s.lighting.sun_direction = Vec3(-0.3, -0.9, 0.1).normalized();  // behind the camera: highlight in view
  const Scene scene(s);
  Renderer flat(s.fixed_camera.model, 0.0, 1);
  const cv::Mat a = flat.render(scene, s.fixed_camera_truth).clone();
  s.look.auto_exposure = false;
  Renderer f = make(field(s));
  const cv::Mat b = f.render(scene, s.fixed_camera_truth).clone();
  cv::Mat1b fruit(b.size(), uchar(0));
  for (int i = 0; i < b.rows * b.cols; ++i)
    if (f.ids()[static_cast<std::size_t>(i)] == 0) fruit(i / b.cols, i % b.cols) = 255;
  cv::Mat grey_a, grey_b;
  cv::cvtColor(a, grey_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, grey_b, cv::COLOR_BGR2GRAY);
  double max_a, max_b;
  cv::minMaxLoc(grey_a, nullptr, &max_a, nullptr, nullptr, fruit);
  cv::minMaxLoc(grey_b, nullptr, &max_b, nullptr, nullptr, fruit);
  EXPECT_LT(max_a, 200);
  EXPECT_GT(max_b, 230);  // near-white specular spot
  // Dimples: fine structure inside the fruit the smooth flat shading lacks.
  cv::Mat lap_a, lap_b;
  cv::Laplacian(grey_a, lap_a, CV_64F);
  cv::Laplacian(grey_b, lap_b, CV_64F);
  cv::Mat1b inner;
  cv::erode(fruit, inner, cv::Mat(), cv::Point(-1, -1), 2);
  cv::Scalar m, sd_a, sd_b;
  cv::meanStdDev(lap_a, m, sd_a, inner);
  cv::meanStdDev(lap_b, m, sd_b, inner);
  EXPECT_GT(sd_b[0], 2.0 * sd_a[0] + 0.5);
}

TEST(FieldLook, GreenFruitAndDryLeavesFollowTheScenarioShares) {
  Scenario s = field(canopy());
  s.look.green_fraction = 1.0;
  s.look.dry_leaf_fraction = 1.0;
  const Scene scene(s);
  Renderer r = make(s);
  const cv::Mat img = r.render(scene, s.fixed_camera_truth).clone();
  EXPECT_EQ(r.fruit_material(scene, 0).ripeness, Ripeness::kGreen);
  const cv::Scalar fruit = mean_over(r, img, 0), leaf = mean_over(r, img, Renderer::kLeaf);
  EXPECT_GT(fruit[1], fruit[2]);  // green above red
  EXPECT_GT(leaf[2], leaf[1]);    // brown leaves: red above green

  s.look.green_fraction = 0.0;
  s.look.dry_leaf_fraction = 0.0;
  Renderer ripe = make(s);
  const cv::Mat img2 = ripe.render(scene, s.fixed_camera_truth).clone();
  EXPECT_EQ(ripe.fruit_material(scene, 0).ripeness, Ripeness::kRipe);
  EXPECT_GT(mean_over(ripe, img2, 0)[2], 1.5 * mean_over(ripe, img2, 0)[1]);
  EXPECT_GT(mean_over(ripe, img2, Renderer::kLeaf)[1], mean_over(ripe, img2, Renderer::kLeaf)[2]);
}

TEST(FieldLook, ShareOfGreenAndHalfRipeFruitIsAsAsked) {
  Look look;
  look.style = "field";
  look.green_fraction = 0.2;
  look.half_ripe_fraction = 0.3;
  int counts[3] = {0, 0, 0};
  for (int id = 0; id < 2000; ++id) ++counts[static_cast<int>(fruit_material(look, id, Vec3(205, 128, 34)).ripeness)];
  EXPECT_NEAR(counts[0] / 2000.0, 0.2, 0.03);
  EXPECT_NEAR(counts[1] / 2000.0, 0.3, 0.03);
}

TEST(FieldLook, AutoExposureCompensatesTheSceneBrightness) {
  Scenario s = field(canopy());
  double means[2];
  for (int k = 0; k < 2; ++k) {
    s.lighting.exposure = k == 0 ? 0.5 : 1.0;
    const Scene scene(s);
    Renderer r = make(s);
    means[k] = cv::mean(r.render(scene, s.fixed_camera_truth))[1];
  }
  EXPECT_NEAR(means[0], means[1], 0.1 * means[1]);
  // Without it the image follows the light.
  s.look.auto_exposure = false;
  for (int k = 0; k < 2; ++k) {
    s.lighting.exposure = k == 0 ? 0.5 : 1.0;
    const Scene scene(s);
    Renderer r = make(s);
    means[k] = cv::mean(r.render(scene, s.fixed_camera_truth))[1];
  }
  EXPECT_LT(means[0], 0.7 * means[1]);
}

TEST(FieldLook, TheGainFollowsABrighterViewWithALag) {
  Scenario s = field(canopy());
  const Scene scene(s);
  Renderer r = make(s);
  r.render(scene, s.fixed_camera_truth);
  const double before = luminance(cv::mean(r.render(scene, s.fixed_camera_truth)));
  // Turn to the open sky above the canopy: the first frame is too bright, later ones less so.
  Placement up = s.fixed_camera_truth;
  up.rotation = look_at_rotation(Vec3::Zero(), Vec3(-1.0, 0.3, 0.0));
  const double first = luminance(cv::mean(r.render(scene, up)));
  double later = first;
  for (int k = 0; k < 15; ++k) later = luminance(cv::mean(r.render(scene, up)));
  EXPECT_GT(first, later + 10);
  EXPECT_GT(first, before);
}

TEST(FieldLook, MotionBlursOnlyAMovingCamera) {
  Scenario s = field(canopy());
  s.fixed_camera.noise_std = 0.0;
  const Scene scene(s);
  const Placement still = s.fixed_camera_truth;
  Placement moved = still;
  moved.position += still.rotation.col(0) * 0.02;  // 2 cm sideways in one frame (0.6 m/s)
  Renderer a = make(s), b = make(s);
  const cv::Mat sharp = a.render(scene, still, still).clone();
  const cv::Mat blurred = b.render(scene, still, moved).clone();
  EXPECT_LT(sharpness(blurred), 0.8 * sharpness(sharp));
  s.look.exposure_time_s = 0.0;  // an instant shutter: no blur
  Renderer c = make(s);
  EXPECT_EQ(cv::norm(c.render(scene, still, moved), sharp, cv::NORM_INF), 0.0);
}

TEST(FieldLook, WhiteBalanceDriftsSlowlyAndIsSeeded) {
  Scenario s = field(canopy());
  s.fixed_camera.noise_std = 0.0;
  const Scene scene(s);
  Renderer r = make(s), twin = make(s);
  double lo = 1e9, hi = -1e9;
  for (int k = 0; k < 150; ++k) {  // 5 s at 30 Hz
    const cv::Mat& img = r.render(scene, s.fixed_camera_truth);
    if (k == 0) EXPECT_EQ(cv::norm(img, twin.render(scene, s.fixed_camera_truth), cv::NORM_INF), 0.0);
    const cv::Scalar m = cv::mean(img);
    lo = std::min(lo, m[0] / m[2]);
    hi = std::max(hi, m[0] / m[2]);
  }
  EXPECT_GT(hi / lo, 1.02);
  s.look.white_balance_drift = 0.0;
  Renderer steady = make(s);
  const cv::Scalar m0 = cv::mean(steady.render(scene, s.fixed_camera_truth));
  for (int k = 0; k < 100; ++k) steady.render(scene, s.fixed_camera_truth);
  const cv::Scalar m1 = cv::mean(steady.render(scene, s.fixed_camera_truth));
  EXPECT_NEAR(m0[0] / m0[2], m1[0] / m1[2], 1e-3);
}

TEST(FieldLook, LeavesCastShadowsOnFruit) {
  Scenario s = field(test::one_fruit());
  s.lighting.sun_direction = Vec3(-1.0, 0.0, 0.0);  // straight above (base x points down)
  Scene open(s);
  Renderer a = make(s);
  const cv::Mat lit = a.render(open, s.fixed_camera_truth).clone();
  // A leaf 10 cm above the fruit, out of the camera's view of it.
  Scene shaded(s);
  Leaf leaf;
  leaf.centre = Vec3(-0.1, 1.0, 0.0);
  leaf.normal = Vec3::UnitX();
  leaf.u = Vec3::UnitY();
  leaf.v = Vec3::UnitZ();
  leaf.half_length = leaf.half_width = 0.06;
  leaf.albedo_rgb = Vec3(50, 100, 30);
  shaded.add_leaf(leaf);
  s.look.auto_exposure = false;  // compare radiance, not what the exposure makes of it
  Renderer b = make(s), c = make(s);
  const cv::Mat with_leaf = b.render(shaded, s.fixed_camera_truth).clone();
  const cv::Mat without = c.render(open, s.fixed_camera_truth).clone();
  ASSERT_EQ(b.visible_pixels()[0], c.visible_pixels()[0]);  // the leaf does not hide it
  EXPECT_LT(luminance(mean_over(b, with_leaf, 0)), 0.8 * luminance(mean_over(c, without, 0)));
  (void)lit;
}

// A flat square 0.2 m wide facing the camera 0.6 m in front of it.
class Square : public Renderer::Primitive {
 public:
  void draw(Renderer::Canvas& canvas, const Mat3& rotation, const Vec3& translation) const override {
    const Eigen::Vector3f c = (rotation * Vec3(0.0, 0.6, 0.0) + translation).cast<float>();
    const Eigen::Vector3f n = (rotation * Vec3(0.0, -1.0, 0.0)).cast<float>();
    const float h = 0.1f;
    const auto box = canvas.pixels((c.x() - h) / c.z(), (c.x() + h) / c.z(), (c.y() - h) / c.z(), (c.y() + h) / c.z());
    for (int y = box.y0; y <= box.y1; ++y)
      for (int x = box.x0; x <= box.x1; ++x) {
        const int i = y * canvas.width() + x;
        const Eigen::Vector3f d = canvas.ray(i);
        const float t = n.dot(c) / n.dot(d);
        const Eigen::Vector3f q = t * d - c;
        if (std::abs(q.x()) <= h && std::abs(q.y()) <= h) canvas.put(i, t, Vec3(200, 200, 200), n);
      }
  }
};

TEST(FieldLook, ExtraPrimitivesAreDrawnLitAndOccludeInBothLooks) {
  for (const char* style : {"flat", "field"}) {
    Scenario s = test::one_fruit();
    s.look.style = style;
    const Scene scene(s);
    Renderer r = make(s);
    r.add_primitive(std::make_shared<Square>());
    const cv::Mat img = r.render(scene, s.fixed_camera_truth).clone();
    EXPECT_EQ(r.ids()[120 * 320 + 160], Renderer::kExtra) << style;
    EXPECT_EQ(r.visible_pixels()[0], 0) << style;  // the fruit behind it is hidden
    const cv::Vec3b centre = img.at<cv::Vec3b>(120, 160);
    EXPECT_GT(centre[1], 60) << style;
    EXPECT_NEAR(centre[0], centre[2], 40) << style;  // grey stays grey-ish
  }
}

}  // namespace
}  // namespace harvest::sim
