// Teach by zooming closed over images (issue 4): an artificial textured
// target, a desired image taken from the goal pose F_d, the camera-in-hand
// rendered from its current pose every frame, ORB + RANSAC + LK matching,
// the TBZ controller with the thesis's deliberately wrong estimates of the
// intrinsics (A_hat) and of the hand-eye rotation (R_r_hat), and a
// simulated end effector. The camera must end within 2 mm and 0.5 degree of
// F_d.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "control/tbz_matches.hpp"
#include "control/tbz_simulation.hpp"
#include "features/matcher.hpp"
#include "synthetic.hpp"

namespace c = harvest::control;
namespace f = harvest::features;
namespace ft = harvest::features::testing;
namespace g = harvest::geometry;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

struct Target {
  cv::Mat1b texture;
  Vector3d centre, e1, e2;  // plane frame in F_d [m]
  double side = 0.36;       // [m]
};

// Texture px -> image px for a camera described by `to_camera`.
template <class ToCamera>
bool plane_homography(const Target& t, const Matrix3d& A, ToCamera to_camera, cv::Matx33d& H) {
  const double n = t.texture.cols;
  std::vector<cv::Point2f> src, dst;
  for (const auto& st : {cv::Point2d(0, 0), cv::Point2d(n, 0), cv::Point2d(n, n), cv::Point2d(0, n)}) {
    const Vector3d X = t.centre + (st.x / n - 0.5) * t.side * t.e1 + (st.y / n - 0.5) * t.side * t.e2;
    const Vector3d Xc = to_camera(X);
    if (Xc.z() < 0.02) return false;
    const Eigen::Vector2d p = (A * Xc).hnormalized();
    src.emplace_back(static_cast<float>(st.x), static_cast<float>(st.y));
    dst.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  H = cv::Matx33d(cv::getPerspectiveTransform(src, dst));
  return true;
}

g::Points2 to_eigen(const std::vector<cv::Point2f>& v, int n) {
  g::Points2 out;
  for (int i = 0; i < n; ++i) out.emplace_back(v[static_cast<std::size_t>(i)].x, v[static_cast<std::size_t>(i)].y);
  return out;
}

}  // namespace

TEST(TbzTextured, CameraInHandReachesTheZoomedViewWithWrongIntrinsics) {
  // Thesis section 5.6.2 cameras and estimates (config/tbz/thesis_sim.yaml).
  const auto thesis = c::ThesisScenario::thesis();
  const Matrix3d A = thesis.A;  // true camera-in-hand intrinsics, 240 x 240
  const cv::Size size(240, 240);
  c::TbzParams params;
  params.A_hat << 120, -4, 122, 0, 121, 123, 0, 0, 1;  // thesis estimate
  params.R_r_hat << 0.9220, -0.1844, 0.3404, 0.3404, 0.8050, -0.4858, -0.1844, 0.5638, 0.8050;
  params.R_r_hat = g::nearest_rotation(params.R_r_hat);
  params.lambda_w = 2.0;
  params.lambda_v = 0.25;
  params.desired_depth_estimate = 0.45;  // true 0.30 m: also wrong
  params.max_linear_speed = 0.381;
  params.max_angular_speed = 1.0;

  Target target;
  target.texture = ft::sticker_texture(480, 21);
  target.centre = Vector3d(0.01, -0.01, 0.30);
  const Matrix3d Rp = g::rotation_from_vector(Vector3d(0.2, -0.15, 0.1));  // tilted plane
  target.e1 = Rp.col(0);
  target.e2 = Rp.col(1);

  // The desired image: what the camera-in-hand sees from F_d (the zoomed
  // fixed-camera image stands for it).
  cv::Matx33d H;
  ASSERT_TRUE(plane_homography(
      target, A, [](const Vector3d& X) { return X; }, H));
  const cv::Mat1b desired = ft::render_plane(target.texture, H, size, 90, 1.0, 1000);
  f::MatcherParams mp;
  mp.orb_features = 500;
  f::DesiredImageMatcher matcher(mp);
  matcher.set_desired(desired);

  // Start: 9.6 cm away and rotated 17 degrees.
  const Matrix3d R0 = g::rotation_from_vector(Vector3d(0.12, -0.18, 0.22));
  const Vector3d p0(0.05, -0.04, -0.07);
  c::HandEyeRig rig(R0, p0, thesis.R_r, thesis.t_r);
  c::TbzController ctrl(params);
  g::Points2 anchors;
  const double dt = 1.0 / 30.0;
  const int frames = 150;  // 5 s at 30 Hz
  int match_failures = 0, min_inliers = 1 << 30;
  double max_v = 0, max_w = 0;
  std::vector<double> time, pos_err;
  const double initial_pos = p0.norm() * 1000, initial_angle = g::angle_axis(R0).theta * 180 / M_PI;
  for (int k = 0; k < frames; ++k) {
    ASSERT_TRUE(plane_homography(
        target, A, [&](const Vector3d& X) { return rig.to_camera(X); }, H))
        << k;
    const cv::Mat1b current = ft::render_plane(target.texture, H, size, 90, 1.0, static_cast<uint64_t>(k));
    const auto m = matcher.match(current);
    c::Twist twist;
    if (m.ok()) {
      min_inliers = std::min(min_inliers, m.num_inliers);
      const auto mm =
          c::measurement_from_matches(to_eigen(m.desired, m.num_inliers), to_eigen(m.current, m.num_inliers), anchors);
      ASSERT_TRUE(mm.ok) << mm.message;
      const auto out = ctrl.step(mm.measurement);
      ASSERT_TRUE(out.ok()) << out.message;
      twist = out.robot;
    } else {
      ++match_failures;  // hold still on a frame without a measurement
    }
    max_v = std::max(max_v, twist.v.norm());
    max_w = std::max(max_w, twist.w.norm());
    rig.apply(twist, dt);
    time.push_back((k + 1) * dt);
    pos_err.push_back(rig.camera_position().norm());
    if (k % 30 == 29)
      std::printf("t %.1f s: position error %.3f mm, angle error %.4f deg, %d inliers\n", (k + 1) * dt,
                  rig.camera_position().norm() * 1000, g::angle_axis(rig.camera_rotation()).theta * 180 / M_PI,
                  m.num_inliers);
  }
  const double pos_mm = rig.camera_position().norm() * 1000;
  const double ang_deg = g::angle_axis(rig.camera_rotation()).theta * 180 / M_PI;
  std::printf(
      "initial %.1f mm %.2f deg -> final %.3f mm %.4f deg; max |v| %.3f m/s, max |w| %.3f rad/s; %d frames without "
      "matches, fewest inliers %d\n",
      initial_pos, initial_angle, pos_mm, ang_deg, max_v, max_w, match_failures, min_inliers);
  EXPECT_LT(pos_mm, 2.0);
  EXPECT_LT(ang_deg, 0.5);
  EXPECT_EQ(match_failures, 0);
  EXPECT_LE(max_v, params.max_linear_speed + 1e-9);
  EXPECT_LE(max_w, params.max_angular_speed + 1e-9);
  // Exponential while far from the noise floor: log-linear fit over the
  // samples above 1 mm.
  const auto fit = c::log_linear_fit(time, pos_err, 1e-3);
  std::printf("position error log-linear fit above 1 mm: slope %.3f /s, R^2 %.3f over %d samples\n", fit.slope, fit.r2,
              fit.n);
  EXPECT_LT(fit.slope, 0.0);
}
