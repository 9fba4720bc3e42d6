// harvest-vision-eval's scoring: true fruit projected to their silhouettes
// (hand-worked sphere geometry), detections assigned to fruit and tallied,
// and the whole tool over a synthetic log with one rendered fruit.
#include "vision/truth_evaluation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "camera/image_codec.hpp"
#include "harvest/image_t.hpp"
#include "runtime/log_io.hpp"
#include "synthetic_scene.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;

namespace harvest::vision {
namespace {

geometry::CameraModel camera() {
  geometry::CameraModel c;
  c.fx = c.fy = 800;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  return c;
}

sim_fruit_truth_t fruit(int id, Eigen::Vector3d p, double diameter, float visible,
                        int8_t state = sim_fruit_truth_t::ON_TREE) {
  sim_fruit_truth_t f{};
  f.sim_id = id;
  f.state = state;
  for (int i = 0; i < 3; ++i) f.position_base[i] = p[i];
  f.diameter_m = diameter;
  f.visible_fraction_fixed = visible;
  return f;
}

sim_truth_t truth_of(std::vector<sim_fruit_truth_t> fruits) {
  sim_truth_t t{};
  t.fruits = std::move(fruits);
  t.num_fruits = static_cast<int32_t>(t.fruits.size());
  return t;
}

TEST(ProjectTruth, SilhouetteOfASphereAhead) {
  // A 80 mm sphere 1 m ahead: its silhouette's half-angle has tan = r / sqrt(d^2 - r^2),
  // so the diameter is 2 * 800 * 0.04 / sqrt(0.9984) = 64.051 px, centred on the principal point.
  const auto t = truth_of({fruit(7, {0, 0, 1}, 0.08, 0.6f)});
  const auto f = project_truth(t, camera(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), false);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 7);
  EXPECT_NEAR(f[0].centre.x(), 319.5, 1e-9);
  EXPECT_NEAR(f[0].centre.y(), 239.5, 1e-9);
  EXPECT_NEAR(f[0].diameter_px, 64.0 / std::sqrt(0.9984), 1e-6);
  EXPECT_DOUBLE_EQ(f[0].depth_m, 1.0);
  EXPECT_FLOAT_EQ(static_cast<float>(f[0].visible), 0.6f);
  // The hand camera has no visibility figure: every fruit counts as seen.
  EXPECT_EQ(project_truth(t, camera(), Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), true)[0].visible, 1.0);
}

TEST(ProjectTruth, CameraPlacementAndSkippedFruit) {
  // Camera 2 m along base x, looking back along -x (optical z = base -x, x = base y, y = base z).
  Eigen::Matrix3d r;  // columns: camera axes in the base frame
  r << 0, 0, -1, 1, 0, 0, 0, 1, 0;
  const Eigen::Vector3d at(2, 0, 0);
  const auto t = truth_of({fruit(1, {1, 0.1, 0}, 0.07, 1),                           // 1 m ahead, 0.1 m right
                           fruit(2, {1, 0, 0}, 0.07, 1, sim_fruit_truth_t::PICKED),  // not on the tree
                           fruit(3, {2.05, 0, 0}, 0.07, 1),                          // behind the camera
                           fruit(4, {1, 5, 0}, 0.07, 1)});                           // far outside the image
  const auto f = project_truth(t, camera(), r, at, false);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].id, 1);
  EXPECT_NEAR(f[0].centre.x(), 319.5 + 80.0, 1e-9);
  EXPECT_NEAR(f[0].centre.y(), 239.5, 1e-9);
  EXPECT_NEAR(f[0].depth_m, 1.0, 1e-12);
}

TEST(TruthEvaluation, DetectionsGoToTheFruitWhoseDiscHoldsThem) {
  TruthFruit a, b;
  a.centre = {100, 100}, a.diameter_px = 64, a.depth_m = 1.05, a.visible = 0.9, a.id = 1;
  b.centre = {300, 100}, b.diameter_px = 40, b.depth_m = 1.5, b.visible = 0.2, b.id = 2;  // too hidden to score
  TruthEvaluation eval(0.5, 800, 0.08);
  const auto on = eval.add_frame({{{105, 100}, 60.8},   // on a, 5 % small
                                  {{80, 110}, 32.0},    // a fragment of a
                                  {{300, 110}, 40.0},   // on b
                                  {{200, 300}, 50.0}},  // on nothing
                                 {a, b});
  ASSERT_EQ(on.size(), 2u);
  EXPECT_EQ(on[0], (std::vector<double>{60.8, 32.0}));
  EXPECT_EQ(on[1], (std::vector<double>{40.0}));
  EXPECT_EQ(eval.unmatched(), 1);
  EXPECT_EQ(eval.fruit_scored(), 1);  // b is below min_visible
  std::ostringstream out;
  eval.report(out, 1, 2.0);
  const std::string s = out.str();
  EXPECT_NE(s.find("fruit-frames with visible >= 0.50: 1"), std::string::npos) << s;
  EXPECT_NE(s.find("  2 detection(s): 1 (100.0 %)"), std::string::npos) << s;
  EXPECT_NE(s.find("diameter error mean -5.0 %"), std::string::npos) << s;
  // Depth 800 * 0.08 / d - 1.05: +3 mm (60.8 px) and +950 mm (32 px), both in the 1000-1100 mm bin.
  EXPECT_NE(s.find("  1000-1100 mm: n    2 mean   +476"), std::string::npos) << s;
  EXPECT_NE(s.find("  1000-1100 mm: n    1 mean     +3"), std::string::npos) << s;
  // The largest detection on a is 5 px from its centre: 7.8 % of its 64 px.
  EXPECT_NE(s.find("  1000-1100 mm: n    1 mean   7.8 rms   7.8 max   7.8"), std::string::npos) << s;
  EXPECT_NE(s.find("detections 4, not on any fruit 1; detector 2.00 ms per frame"), std::string::npos) << s;
}

// A log with a truth snapshot and one rendered frame of it: the detector
// finds the fruit at its true place and size.
TEST(RunTruthEvaluation, ScoresARenderedFruit) {
  const geometry::CameraModel cam = camera();
  const Eigen::Vector3d centre(0.05, -0.02, 0.8);
  cv::Mat3b img = test::background(cam.width, cam.height);
  test::render_sphere(img, cam, centre, 0.04);
  image_t msg{};
  camera::encode_image(img, false, 90, msg);
  const auto truth = truth_of({fruit(3, centre, 0.08, 1.0f)});
  const std::vector<rt::LogRecord> log = {{0, "CAMERA_FIXED", rt::encode(msg)},  // before any truth: not scored
                                          {1, "SIM_TRUTH", rt::encode(truth)},
                                          {2, "CAMERA_FIXED", rt::encode(msg)}};
  DetectorNodeConfig config;
  config.calibration = cam;
  config.detector = DetectorConfig::canopy();
  config.detector.fruit_diameter_m = 0.08;
  TrueCamera truth_camera;
  truth_camera.model = cam;
  TruthEvalOptions options;
  std::ostringstream out, err;
  EXPECT_EQ(run_truth_evaluation(log, config, truth_camera, options, out, err), 0) << err.str();
  const std::string s = out.str();
  EXPECT_NE(s.find("frames 1, fruit-frames with visible >= 0.50: 1"), std::string::npos) << s;
  EXPECT_NE(s.find("  1 detection(s): 1 (100.0 %)"), std::string::npos) << s;
  EXPECT_NE(s.find("within 10 %: 1 of 1"), std::string::npos) << s;
  EXPECT_NE(s.find("not on any fruit 0"), std::string::npos) << s;

  // Overlays that cannot be written are an error naming the file; the scores still come.
  ht::TempDir dir;
  options.overlay_dir = dir / "missing" / "folder";
  std::ostringstream out2, err2;
  EXPECT_EQ(run_truth_evaluation(log, config, truth_camera, options, out2, err2), 1);
  EXPECT_NE(err2.str().find("cannot write"), std::string::npos) << err2.str();
  EXPECT_NE(err2.str().find("fixed_00001.png"), std::string::npos) << err2.str();
  EXPECT_NE(out2.str().find("within 10 %: 1 of 1"), std::string::npos) << out2.str();
  // Into a folder that exists they are written.
  options.overlay_dir = dir.path();
  std::ostringstream out3, err3;
  EXPECT_EQ(run_truth_evaluation(log, config, truth_camera, options, out3, err3), 0) << err3.str();
  EXPECT_TRUE(std::filesystem::is_regular_file(dir / "fixed_00001.png"));
  EXPECT_TRUE(std::filesystem::is_regular_file(dir / "mask_00001.png"));
}

}  // namespace
}  // namespace harvest::vision
