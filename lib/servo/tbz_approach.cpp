#include "servo/tbz_approach.hpp"

#include "control/tbz_matches.hpp"

namespace harvest::servo {

TbzApproachParams tbz_params_from(const ServoConfig& config) {
  TbzApproachParams p;
  const auto& c = config.hand_camera;
  p.controller.A_hat << c.fx, c.skew, c.cx, 0, c.fy, c.cy, 0, 0, 1;
  p.controller.max_linear_speed = config.max_linear_speed;
  p.controller.max_angular_speed = config.max_angular_speed;
  return p;
}

namespace {
control::TbzParams controller_params(const TbzApproachParams& p) {
  control::TbzParams c = p.controller;
  if (p.hand_eye_from_poses) c.R_r_hat = Eigen::Matrix3d::Identity();
  return c;
}
}  // namespace

TbzApproach::TbzApproach(TbzApproachParams params) : params_(std::move(params)), ctrl_(controller_params(params_)) {}

void TbzApproach::reset() {
  anchors_.clear();
  matches_.reset();
  ctrl_.reset();
  last_ = {};
  refusal_.clear();
}

void TbzApproach::on_matches(const feature_matches_t& m) { matches_ = m; }

ApproachOutput TbzApproach::update(const ApproachInput& in) {
  ApproachOutput out;
  out.error.setZero();
  const Eigen::Matrix3d R_tool = in.tool.rotation();
  if (in.forward_speed) {  // IR guidance: straight on along the camera axis
    out.twist.linear = in.camera.rotation() * Eigen::Vector3d(0, 0, *in.forward_speed);
    refusal_.clear();
    return out;
  }
  if (!matches_) {
    refusal_ = "no FEATURE_MATCHES yet";
    return out;
  }
  const feature_matches_t& m = *matches_;
  if (m.status != feature_matches_t::STATUS_OK) {
    refusal_ = "feature matches: " + m.status_text;
    return out;
  }
  if (rt::to_seconds(in.now - m.header.utime) > params_.max_match_age_s) {
    refusal_ = "feature matches are stale";
    return out;
  }
  geometry::Points2 d, c;
  const int n = std::min<int>(m.num_inliers, static_cast<int>(m.desired_u_px.size()));
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    d.emplace_back(m.desired_u_px[k], m.desired_v_px[k]);
    c.emplace_back(m.current_u_px[k], m.current_v_px[k]);
  }
  const auto mm = control::measurement_from_matches(d, c, anchors_);
  if (!mm.ok) {
    refusal_ = mm.message;
    return out;
  }
  last_ = ctrl_.step(mm.measurement);
  if (!last_.ok()) {
    refusal_ = last_.message;
    return out;
  }
  refusal_.clear();
  // With the hand-eye rotation taken from the poses the controller works in
  // the camera frame (R_r_hat = I) and its twist is rotated into the base
  // frame with the camera's orientation; otherwise with the tool's.
  const Eigen::Matrix3d R_out = params_.hand_eye_from_poses ? in.camera.rotation() : R_tool;
  out.twist.linear = R_out * last_.robot.v;
  out.twist.angular = R_out * last_.robot.w;
  out.error = last_.e_v;
  return out;
}

}  // namespace harvest::servo
