#include "servo/approach.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace harvest::servo {
namespace {

// A distortion-free camera at the base origin looking along base z; the fruit
// `lateral` metres off the axis along x, 0.1 m ahead, its centroid where the
// pinhole model puts it.
ApproachInput at_fruit(double lateral, const geometry::CameraModel& k, std::optional<double> forward) {
  ApproachInput in;
  in.fruit_base = Eigen::Vector3d(lateral, 0.0, 0.1);
  in.pixel = PixelMeasurement{k.cx + k.fx * lateral / 0.1, k.cy, 1};
  in.forward_speed = forward;
  return in;
}

geometry::CameraModel pinhole() {
  geometry::CameraModel k = kDefaultHandCamera;
  k.dist = {};
  return k;
}

// Hand-worked: the image was taken with the camera 30 mm to the side of
// where it is now (x = 0.03), the fruit centred in it 0.2 m ahead: the fruit
// is at (0.03, 0, 0.2), not on the newest camera's axis at (0, 0, 0.2).
TEST(SeenInBase, APixelIsSeenFromWhereTheCameraTookTheImage) {
  const geometry::CameraModel k = pinhole();
  Eigen::Isometry3d then = Eigen::Isometry3d::Identity();
  then.translation() = Eigen::Vector3d(0.03, 0.0, 0.0);
  const Eigen::Vector3d fruit(0.03, 0.0, 0.2);
  PixelMeasurement seen{k.cx, k.cy, 1};
  EXPECT_NEAR((seen_in_base(k, Eigen::Isometry3d::Identity(), seen, fruit) - Eigen::Vector3d(0.0, 0.0, 0.2)).norm(),
              0.0, 1e-12);  // no pose of its own: seen from the newest camera
  seen.camera = then;
  EXPECT_NEAR((seen_in_base(k, Eigen::Isometry3d::Identity(), seen, fruit) - fruit).norm(), 0.0, 1e-12);
  // Its depth is taken along the image's own optical axis too: the same pixel 10 px right of the centre, the
  // camera then 0.05 m nearer the fruit: depth 0.15, x = 0.03 + 10 / fx * 0.15.
  then.translation().z() = 0.05;
  seen.camera = then;
  seen.u = k.cx + 10.0;
  const Eigen::Vector3d p = seen_in_base(k, Eigen::Isometry3d::Identity(), seen, fruit);
  EXPECT_NEAR(p.x(), 0.03 + 10.0 / k.fx * 0.15, 1e-9);
  EXPECT_NEAR(p.z(), 0.2, 1e-12);
}

// Hand-worked: 20 mm off the axis, 0.1 m to go, kp 2/s, tolerance 5 mm: the
// centring needs ln(20/5) / 2 = 0.693 s, so the gripper may advance at no
// more than 0.1 / 0.693 = 0.1443 m/s, whatever the IR phase asks (0.3).
TEST(ReconstructionApproach, AdvancesNoFasterThanTheCentringConverges) {
  Gains g;
  g.kp_lateral = 2.0;
  g.centring_tolerance = 0.005;
  ReconstructionApproach a(g, pinhole());
  const ApproachOutput out = a.update(at_fruit(0.02, pinhole(), 0.3));
  EXPECT_NEAR(out.error.x(), 0.02, 1e-9);
  EXPECT_NEAR(out.twist.linear.z(), 2.0 * 0.1 / std::log(4.0), 1e-9);
  EXPECT_NEAR(out.twist.linear.x(), 2.0 * 0.02, 1e-9);  // eq. 6-25 centring unchanged
  // Eq. 6-27 outside the IR phase is bounded the same way (kp_depth 1: 0.1 m/s
  // asked; the bound is looser here, 0.144 m/s).
  ReconstructionApproach b(g, pinhole());
  EXPECT_NEAR(b.update(at_fruit(0.02, pinhole(), std::nullopt)).twist.linear.z(), 0.1, 1e-9);
}

TEST(ReconstructionApproach, CentredWithinTheToleranceTheForwardSpeedIsAsAsked) {
  Gains g;
  g.centring_tolerance = 0.005;
  ReconstructionApproach a(g, pinhole());
  EXPECT_NEAR(a.update(at_fruit(0.004, pinhole(), 0.3)).twist.linear.z(), 0.3, 1e-9);
  g.centring_tolerance = 0.0;  // no bound
  ReconstructionApproach b(g, pinhole());
  EXPECT_NEAR(b.update(at_fruit(0.05, pinhole(), 0.3)).twist.linear.z(), 0.3, 1e-9);
}

// A fruit swaying +-15 mm at 0.4 Hz across the axis, 0.3 m ahead, followed
// for one whole period under IR guidance and last seen at the crest of its
// swing: the gripper is steered to the middle of the sway (the mean over the
// window), not to where the fruit happens to be.
TEST(ReconstructionApproach, UnderIrGuidanceCentresOnTheMiddleOfTheSway) {
  Gains g;
  g.kp_lateral = 2.0;
  g.kd_lateral = 0.0;
  g.sway_window = 2.5;
  auto follow = [&](Gains gains, std::optional<double> forward, std::optional<double> window = std::nullopt) {
    ReconstructionApproach a(gains, pinhole());
    ApproachOutput out;
    for (int i = 0; i <= 75; ++i) {  // 30 Hz for 2.5 s, from a quarter period: ends at the crest
      const double t = 0.625 + i / 30.0;
      const double x = 0.015 * std::sin(2.0 * std::numbers::pi * 0.4 * t);
      ApproachInput in;
      in.now = rt::from_seconds(t);
      in.fruit_base = Eigen::Vector3d(x, 0.0, 0.3);
      in.pixel = PixelMeasurement{pinhole().cx + pinhole().fx * x / 0.3, pinhole().cy, in.now};
      in.forward_speed = forward;
      in.mean_window = window;
      out = a.update(in);
    }
    return out;
  };
  const ApproachOutput mean = follow(g, 0.1);
  EXPECT_LT(std::abs(mean.error.x()), 0.001);  // the middle of the sway (the window's 76 samples: not exactly 0)
  EXPECT_LT(std::abs(mean.twist.linear.x()), 0.002);
  // Before IR guidance, and with no window, the newest position: the crest.
  EXPECT_NEAR(follow(g, std::nullopt).error.x(), 0.015, 1e-6);
  // A window given with the input (gains.still_window on a still tree) overrides gains.sway_window.
  EXPECT_NEAR(follow(g, 0.1, 0.0).error.x(), 0.015, 1e-6);
  g.sway_window = 0.0;
  EXPECT_NEAR(follow(g, 0.1).error.x(), 0.015, 1e-6);
  EXPECT_LT(std::abs(follow(g, 0.1, 2.5).error.x()), 0.001);
}

// A still fruit 10 mm off the axis, 0.1 m ahead, seen whole for 0.3 s at 30 Hz, then for 1 s filling the image: the
// detector's centre of its visible part lies toward the image centre (here by 6 mm at the fruit's depth: it looks
// 4 mm off the axis). With gains.whole_views the whole views stay the mean (10 mm, though a second has passed: the
// window counts back from the newest whole view); without, the cut views take over.
TEST(ReconstructionApproach, WithWholeViewsAFruitFillingTheImageIsNotCentredOn) {
  Gains g;
  g.kd_lateral = 0.0;
  auto follow = [](const Gains& gains) {
    const geometry::CameraModel k = pinhole();
    ReconstructionApproach a(gains, k);
    ApproachOutput out;
    for (int i = 0; i <= 39; ++i) {
      ApproachInput in = at_fruit(0.01, k, 0.1);
      in.now = rt::from_seconds(i / 30.0);
      in.pixel->utime = in.now;
      in.mean_window = 0.3;
      in.pixel_whole = i < 9;
      if (!in.pixel_whole) in.pixel->u -= 0.006 / 0.1 * k.fx;
      out = a.update(in);
    }
    return out;
  };
  g.whole_views = true;
  EXPECT_NEAR(follow(g).error.x(), 0.01, 1e-9);
  g.whole_views = false;
  EXPECT_NEAR(follow(g).error.x(), 0.004, 1e-9);  // the window's nine views, all cut
}

// The camera beside the gripper axis and tilted (hand-eye not the identity):
// the fruit is centred on the gripper axis, not on the optical axis.
// Hand-worked: tool at the origin looking along base z; camera 20 mm along
// tool x, 40 mm behind the tool point, turned 2 deg about tool y; fruit on
// the tool axis 0.2 m ahead. In the camera frame the fruit is at
// R^T (p - c) = Ry(-2 deg) (-0.02, 0, 0.24): x = -0.02 cos 2 - 0.24 sin 2 =
// -0.02836 m, z = -0.02 sin 2 + 0.24 cos 2 = 0.23916 m, so its pixel is
// off-centre by fx * x / z, yet there is nothing to correct: the lateral
// error is zero and the twist goes straight along the gripper axis. Composed
// the wrong way round (camera pose taken as hand-eye * tool, or the
// camera-frame error used as is) the same pixel asks for a 28 mm correction.
TEST(ReconstructionApproach, CentresTheFruitOnTheGripperAxisNotTheCameraAxis) {
  Gains g;
  g.kp_lateral = 2.0;
  g.kd_lateral = 0.0;
  g.centring_tolerance = 0.0;
  ReconstructionApproach a(g, pinhole());
  const double s = std::sin(2.0 * std::numbers::pi / 180), c = std::cos(2.0 * std::numbers::pi / 180);
  ApproachInput in;
  in.tool = Eigen::Isometry3d::Identity();
  in.camera = Eigen::Isometry3d::Identity();
  in.camera.linear() = Eigen::AngleAxisd(2.0 * std::numbers::pi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  in.camera.translation() << 0.02, 0.0, -0.04;
  in.fruit_base = Eigen::Vector3d(0.0, 0.0, 0.2);
  const double x = -0.02 * c - 0.24 * s, z = -0.02 * s + 0.24 * c;
  EXPECT_NEAR(x, -0.02836, 1e-5);
  in.pixel = PixelMeasurement{pinhole().cx + pinhole().fx * x / z, pinhole().cy, 1};
  const ApproachOutput out = a.update(in);
  EXPECT_NEAR(out.error.x(), 0.0, 1e-9);
  EXPECT_NEAR(out.error.y(), 0.0, 1e-9);
  EXPECT_NEAR(out.error.z(), 0.2, 1e-9);  // ahead of the tool point
  EXPECT_NEAR(out.twist.linear.x(), 0.0, 1e-9);
  EXPECT_GT(out.twist.linear.z(), 0.0);
  // A fruit 10 mm beside the gripper axis (tool x) is corrected toward +x,
  // in the tool frame: kp * 0.01 = 0.02 m/s along base x.
  ReconstructionApproach b(g, pinhole());
  in.fruit_base = Eigen::Vector3d(0.01, 0.0, 0.2);
  const Eigen::Vector3d pc = in.camera.inverse() * in.fruit_base;
  in.pixel =
      PixelMeasurement{pinhole().cx + pinhole().fx * pc.x() / pc.z(), pinhole().cy + pinhole().fy * pc.y() / pc.z(), 1};
  EXPECT_NEAR(b.update(in).twist.linear.x(), 0.02, 1e-9);
}

}  // namespace
}  // namespace harvest::servo
