#include "vision/reconstructor.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numbers>

#include "config/config.hpp"
#include "geometry/pose_msg.hpp"
#include "vision/reconstruction.hpp"
#include "vision/tracking.hpp"

namespace harvest::vision {
namespace {

geometry::CameraModel pinhole(double fx, double fy) {
  return geometry::CameraModel::from_thesis(fx, fy, std::numbers::pi / 2, 319.5, 239.5, 640, 480);
}

TEST(Reconstruction, DepthAndPositionFollowEq6_11And6_12) {
  const geometry::CameraModel cam = pinhole(833.57, 767.02);
  const FruitStatistics fruit{0.0725, 0.003};
  const double u = 400, v = 150, d = 60;
  const PointEstimate e = reconstruct_in_camera(cam, u, v, d, fruit, {1.0, 1.0});
  const double z = (833.57 + 767.02) * 0.0725 / (2 * d);  // eq. 6-11
  EXPECT_NEAR(e.position.z(), z, 1e-12);
  EXPECT_NEAR(e.depth_along_x, 833.57 * 0.0725 / d, 1e-12);  // eq. 6-10
  EXPECT_NEAR(e.depth_along_y, 767.02 * 0.0725 / d, 1e-12);
  EXPECT_NEAR(e.position.x(), (u - 319.5) / 833.57 * z, 1e-12);  // eq. 6-12
  EXPECT_NEAR(e.position.y(), (v - 239.5) / 767.02 * z, 1e-12);
  // Depth variance from the diameter spread and the pixel noise.
  const double rel2 = std::pow(0.003 / 0.0725, 2) + std::pow(1.0 / d, 2);
  EXPECT_NEAR(e.covariance(2, 2), z * z * rel2, 1e-12);
  EXPECT_NEAR(e.covariance(0, 2), e.position.x() / z * z * z * rel2, 1e-12);
  EXPECT_GT(e.covariance(0, 0), 0);
}

TEST(Reconstruction, DistortionIsUndone) {
  geometry::CameraModel cam = pinhole(800, 800);
  cam.dist = {-0.2, 0.05, 0, 0, 0};
  const Eigen::Vector3d truth(0.12, -0.08, 0.6);
  const double diameter = 0.07;
  // Apparent diameter through the distorted model, measured along x.
  const Eigen::Vector2d c = cam.project(truth);
  const double dpx = cam.project(truth + Eigen::Vector3d(diameter / 2, 0, 0)).x() -
                     cam.project(truth - Eigen::Vector3d(diameter / 2, 0, 0)).x();
  const PointEstimate e = reconstruct_in_camera(cam, c.x(), c.y(), dpx, {diameter, 0.003}, {1, 1});
  EXPECT_NEAR(e.depth_along_x, 0.6, 0.002);
  EXPECT_NEAR(e.position.x(), 0.12, 0.002);
}

// Eq. 4-1 (p_base = R_ef p_cam + T_ef, T_ef = (-254, 196.85, -381) mm) on a
// point worked by hand: p_cam = (100, -50, 900) mm; R_ef p_cam = (y, z, -x) =
// (-50, 900, -100) mm; plus T_ef: (-304, 1096.85, -481) mm. (That the
// simulator's truth agrees with the thesis's measured fruit positions is
// checked in tests/unit/sim/scenario_test.cpp against tables 6-7 and 6-9.)
TEST(Reconstruction, FixedCameraExtrinsicIsEq4_1) {
  const Eigen::Isometry3d t = thesis_fixed_camera_extrinsic();
  const Eigen::Vector3d base = t * Eigen::Vector3d(0.100, -0.050, 0.900);
  EXPECT_NEAR((base - Eigen::Vector3d(-0.304, 1.09685, -0.481)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((t.inverse() * base - Eigen::Vector3d(0.100, -0.050, 0.900)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(t.linear().determinant(), -1.0, 1e-12);  // a reflection, as the thesis prints it
}

TEST(PixelTracker, KeepsIdsAcrossFrames) {
  PixelTracker t(1.0, 2, 0);
  EXPECT_EQ(t.update({{100, 100, 40}, {300, 100, 40}}), (std::vector<int32_t>{0, 1}));
  // Order swapped and both moved a little; a third fruit appears.
  EXPECT_EQ(t.update({{305, 104, 40}, {500, 300, 30}, {96, 98, 41}}), (std::vector<int32_t>{1, 2, 0}));
  // Fruit 1 hidden for two frames, then back: same id; then gone too long: new id.
  t.update({{96, 98, 41}});
  t.update({{96, 98, 41}});
  EXPECT_EQ(t.update({{96, 98, 41}, {305, 104, 40}}), (std::vector<int32_t>{0, 1}));
  for (int i = 0; i < 3; ++i) t.update({});
  EXPECT_EQ(t.update({{305, 104, 40}}), (std::vector<int32_t>{3}));
  // A jump larger than the gate is a different fruit.
  PixelTracker g(1.0, 2, 0);
  g.update({{100, 100, 20}});
  EXPECT_EQ(g.update({{150, 100, 20}}), (std::vector<int32_t>{1}));
}

// ---- thesis experiment II (section 6.4.3, table 6-7) ----

fruit_t detection(const geometry::CameraModel& cam, const Eigen::Vector3d& p_cam, double diameter_m) {
  fruit_t f{};
  const Eigen::Vector2d px = cam.project(p_cam);
  f.u_px = static_cast<float>(px.x());
  f.v_px = static_cast<float>(px.y());
  f.diameter_px = static_cast<float>(0.5 * (cam.fx + cam.fy) * diameter_m / p_cam.z());
  f.confidence = 1;
  return f;
}

fruit_detections_t detections(const std::string& camera, int64_t utime, std::vector<fruit_t> fruits, int selected) {
  fruit_detections_t d{};
  d.header.utime = utime;
  d.camera = camera;
  d.status = fruit_detections_t::STATUS_OK;
  d.fruits = std::move(fruits);
  d.num_fruits = static_cast<int32_t>(d.fruits.size());
  d.selected_index = selected;
  return d;
}

// A robot state with the camera-in-hand at `camera`. The tool is elsewhere
// (the camera sits 17 mm off the gripper axis, 48 mm behind the tool point,
// tilted 3 degrees): the hand camera's pose is ROBOT_STATE's camera_pose, and
// a reconstructor that placed the camera at the tool would miss by that much.
robot_state_t state_at(int64_t utime, const Eigen::Isometry3d& camera) {
  Eigen::Isometry3d tool_to_camera = Eigen::Isometry3d::Identity();
  tool_to_camera.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, -1, 0.5).normalized()).toRotationMatrix();
  tool_to_camera.translation() << 0.014, -0.009, -0.048;
  robot_state_t s{};
  s.header.utime = utime;
  s.tool_pose = geometry::to_pose(camera * tool_to_camera.inverse());
  s.camera_pose = geometry::to_pose(camera);
  return s;
}

class ExperimentII : public ::testing::Test {
 protected:
  void SetUp() override {
    config_.fixed_camera = pinhole(833.57, 767.02);
    config_.hand_camera = pinhole(833.57, 767.02);
    // Truth: eq. 4-1 rotation with the table-consistent translation; the
    // software keeps eq. 4-1 (an imperfect calibration, as in the field).
    truth_fixed_ = thesis_fixed_camera_extrinsic();
    truth_fixed_.translation() << -0.2413, 0.2286, -0.4005;
    // Camera-in-hand 0.5 m in front of the fruit, looking along base +y.
    hand_ = Eigen::Isometry3d::Identity();
    hand_.linear() << 1, 0, 0, 0, 0, 1, 0, -1, 0;
    hand_.translation() << -0.23, 0.50, -0.48;
  }
  Eigen::Vector3d in_hand(const Eigen::Vector3d& base) const { return hand_.inverse() * base; }

  ReconstructorConfig config_;
  Eigen::Isometry3d truth_fixed_, hand_;
  // Table 6-7: fruit #1 and #2 in the fixed camera frame.
  const Eigen::Vector3d fruit1_cam_{0.1397, -0.0257, 0.7874};
  const Eigen::Vector3d fruit2_cam_{-0.0254, 0.17272, 0.9388};
  const double true_diameter_ = 0.0752;  // a fruit 2.7 mm larger than the statistical mean
};

TEST_F(ExperimentII, FixedCameraFruitIsKeptInTheHandView) {
  Reconstructor r(config_);
  // The fixed camera sees fruit #1 only (#2 is hidden from it), over a few frames.
  for (int64_t k = 0; k < 3; ++k) {
    const auto t = r.on_fixed(
        detections("fixed", 1'000'000 + 33'000 * k, {detection(config_.fixed_camera, fruit1_cam_, true_diameter_)}, 0));
    ASSERT_TRUE(t);
    ASSERT_EQ(t->num_targets, 1);
    EXPECT_EQ(t->targets[0].fruit_id, 0);
    EXPECT_EQ(t->selected_fruit_id, 0);
    EXPECT_EQ(t->source_camera, "fixed");
  }
  harvest_status_t status{};
  status.current_fruit_id = 0;
  r.on_harvest_status(status);

  // The camera-in-hand sees both; its own detector would prefer #2 (index 0).
  const Eigen::Vector3d f1 = truth_fixed_ * fruit1_cam_, f2 = truth_fixed_ * fruit2_cam_;
  r.on_robot_state(state_at(1'980'000, hand_));
  r.on_robot_state(state_at(2'020'000, hand_));
  for (int k = 0; k < 3; ++k) {
    const auto t = r.on_hand(detections("hand", 2'000'000 + k * 10'000,
                                        {detection(config_.hand_camera, in_hand(f2), true_diameter_),
                                         detection(config_.hand_camera, in_hand(f1), true_diameter_)},
                                        0));
    if (k > 0) {
      ASSERT_TRUE(t) << r.last_error();
      continue;
    }
    ASSERT_TRUE(t) << r.last_error();
    ASSERT_EQ(t->num_targets, 2);
    EXPECT_EQ(t->targets[1].fruit_id, 0);                    // fruit #1 keeps its global id
    EXPECT_GE(t->targets[0].fruit_id, kUnassociatedIdBase);  // #2 is new to the system
    EXPECT_EQ(t->selected_fruit_id, 0);
    EXPECT_TRUE(t->targets[1].selected);
    EXPECT_FALSE(t->targets[0].selected);
    // The close view places fruit #1 within 2 cm of the truth (the size spread).
    const Eigen::Vector3d p(t->targets[1].position_base);
    EXPECT_LT((p - f1).norm(), 0.02);
  }
  r.on_robot_state(state_at(2'060'000, hand_));
  // Without the controller's choice the fixed camera's selection still rules.
  Reconstructor r2(config_);
  r2.on_fixed(detections("fixed", 1'000'000, {detection(config_.fixed_camera, fruit1_cam_, true_diameter_)}, 0));
  r2.on_robot_state(state_at(1'990'000, hand_));
  const auto t2 = r2.on_hand(detections("hand", 2'000'000,
                                        {detection(config_.hand_camera, in_hand(f2), true_diameter_),
                                         detection(config_.hand_camera, in_hand(f1), true_diameter_)},
                                        0));
  ASSERT_TRUE(t2);
  EXPECT_EQ(t2->selected_fruit_id, 0);
}

// TARGETS name the camera's pose, so a consumer can form each target's line
// of sight: the fixed camera's calibrated extrinsic, the camera-in-hand at
// the image time; every target lies on the ray from it through the pixel.
TEST_F(ExperimentII, TargetsCarryTheirCamerasPose) {
  Reconstructor r(config_);
  const auto fixed =
      r.on_fixed(detections("fixed", 1'000'000, {detection(config_.fixed_camera, fruit1_cam_, 0.07)}, 0));
  ASSERT_TRUE(fixed);
  ASSERT_TRUE(fixed->camera_known);
  const Eigen::Vector3d c(fixed->camera_position_base);
  EXPECT_TRUE(c.isApprox(config_.fixed_extrinsic.translation(), 1e-12));
  const Eigen::Vector3d p(fixed->targets[0].position_base);
  const Eigen::Vector3d in_cam = config_.fixed_extrinsic.linear().inverse() * (p - c);
  EXPECT_NEAR(in_cam.normalized().dot(fruit1_cam_.normalized()), 1.0, 1e-9);  // on the pixel's ray
  r.on_robot_state(state_at(1'980'000, hand_));
  r.on_robot_state(state_at(2'020'000, hand_));
  const Eigen::Vector3d f1 = truth_fixed_ * fruit1_cam_;
  const auto hand = r.on_hand(detections("hand", 2'000'000, {detection(config_.hand_camera, in_hand(f1), 0.07)}, 0));
  ASSERT_TRUE(hand) << r.last_error();
  ASSERT_TRUE(hand->camera_known);
  EXPECT_TRUE(Eigen::Vector3d(hand->camera_position_base).isApprox(hand_.translation(), 1e-9));
  const Eigen::Vector3d ph(hand->targets[0].position_base);
  EXPECT_NEAR((hand_.inverse() * ph).normalized().dot(in_hand(f1).normalized()), 1.0, 1e-9);  // on the pixel's ray
}

TEST_F(ExperimentII, OtherFruitAloneDoesNotTakeTheChosenId) {
  Reconstructor r(config_);
  r.on_fixed(detections("fixed", 1'000'000, {detection(config_.fixed_camera, fruit1_cam_, true_diameter_)}, 0));
  r.on_robot_state(state_at(2'000'000, hand_));
  const Eigen::Vector3d f2 = truth_fixed_ * fruit2_cam_;
  const auto t =
      r.on_hand(detections("hand", 2'000'000, {detection(config_.hand_camera, in_hand(f2), true_diameter_)}, 0));
  ASSERT_TRUE(t);
  EXPECT_GE(t->targets[0].fruit_id, kUnassociatedIdBase);
}

TEST_F(ExperimentII, HandImageWithoutRobotStateIsRefused) {
  Reconstructor r(config_);
  const auto none = r.on_hand(detections("hand", 2'000'000, {}, -1));
  EXPECT_FALSE(none);
  EXPECT_NE(r.last_error().find("no robot state"), std::string::npos);
  r.on_robot_state(state_at(1'000'000, hand_));  // a second too old
  EXPECT_FALSE(r.on_hand(detections("hand", 2'000'000, {}, -1)));
}

TEST(Reconstructor, BadDetectionsAreReportedNotUsed) {
  ReconstructorConfig c;
  c.fixed_camera = pinhole(800, 800);
  c.hand_camera = c.fixed_camera;
  Reconstructor r(c);
  fruit_detections_t bad = detections("fixed", 1, {}, -1);
  bad.status = fruit_detections_t::STATUS_BAD_IMAGE;
  bad.status_text = "corrupt JPEG";
  EXPECT_FALSE(r.on_fixed(bad));
  EXPECT_NE(r.last_error().find("corrupt JPEG"), std::string::npos);
  fruit_t zero{};
  EXPECT_FALSE(r.on_fixed(detections("fixed", 2, {zero}, 0)));
  EXPECT_TRUE(r.known_fruit().empty());
}

TEST(ReconstructorConfig, LoadsShippedFileAndRejectsBadExtrinsic) {
  auto doc = config::Document::load_file("config/vision/reconstructor.yaml");
  const ReconstructorConfig c = ReconstructorConfig::from_yaml(doc.root());
  doc.check_unused();
  EXPECT_NEAR(c.fixed_extrinsic.translation().x(), -0.254, 1e-12);
  EXPECT_EQ(c.fixed_camera.width, 640);
  // The thesis's eq. 4-1 matrix is a reflection (det -1) and is accepted for
  // the fixed camera.
  EXPECT_NEAR(c.fixed_extrinsic.linear().determinant(), -1.0, 1e-12);
  const auto file = std::filesystem::temp_directory_path() / ("bad_extrinsic_" + std::to_string(::getpid()) + ".yaml");
  {
    std::ofstream out(file);
    out << "rotation: [1, 0, 0, 0, 1, 0, 0, 0, 2]\ntranslation_mm: [0, 0, 0]\n";
  }
  auto bad = config::Document::load_string("camera_fixed:\n  extrinsic: " + file.string() + "\n");
  try {
    ReconstructorConfig::from_yaml(bad.root());
    ADD_FAILURE() << "a non-orthonormal extrinsic was accepted";
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("orthonormal"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
  std::filesystem::remove(file);
  auto missing = config::Document::load_string("camera_fixed:\n  calibration: /nonexistent/cam.yaml\n");
  try {
    ReconstructorConfig::from_yaml(missing.root());
    ADD_FAILURE();
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/cam.yaml"), std::string::npos) << e.what();
  }
}

// With no configuration the defaults apply unchanged: the default rotation is
// written back to the configuration row-major and read back the same (it was
// once emitted in Eigen's column-major order and came back transposed).
TEST(ReconstructorConfig, DefaultsRoundTripWithoutTransposing) {
  auto doc = config::Document::load_string("{}\n");
  const ReconstructorConfig c = ReconstructorConfig::from_yaml(doc.root());
  EXPECT_TRUE(c.fixed_extrinsic.matrix().isApprox(thesis_fixed_camera_extrinsic().matrix(), 1e-12));
  auto again = config::Document::load_string(doc.emit());
  const ReconstructorConfig c2 = ReconstructorConfig::from_yaml(again.root());
  EXPECT_TRUE(c2.fixed_extrinsic.matrix().isApprox(thesis_fixed_camera_extrinsic().matrix(), 1e-12));
}

}  // namespace
}  // namespace harvest::vision
