#include "servo/tbz_approach.hpp"

#include <cmath>
#include <cstdio>

#include "control/tbz_matches.hpp"

namespace harvest::servo {

TbzApproachParams tbz_params_from(const ServoConfig& config) {
  TbzApproachParams p;
  const auto& c = config.hand_camera;
  p.controller.A_hat << c.fx, c.skew, c.cx, 0, c.fy, c.cy, 0, 0, 1;
  p.controller.max_linear_speed = config.max_linear_speed;
  p.controller.max_angular_speed = config.max_angular_speed;
  p.controller.lambda_w = config.tbz.lambda_w;
  p.controller.lambda_v = config.tbz.lambda_v;
  p.controller.desired_depth_estimate = config.tbz.desired_depth_estimate;
  p.max_match_age_s = config.tbz.max_match_age_s;
  p.fallback_after_s = config.tbz.fallback_after_s;
  p.min_verified_share = config.tbz.min_verified_share;
  p.desired_wait_s = config.tbz.desired_wait_s;
  p.arrived_rotation = config.tbz.arrived_rotation;
  p.arrived_translation = config.tbz.arrived_translation;
  p.gains = config.gains;
  p.camera = config.hand_camera;
  return p;
}

namespace {
control::TbzParams controller_params(const TbzApproachParams& p) {
  control::TbzParams c = p.controller;
  if (p.hand_eye_from_poses) c.R_r_hat = Eigen::Matrix3d::Identity();
  return c;
}
}  // namespace

TbzApproach::TbzApproach(TbzApproachParams params)
    : params_(std::move(params)), ctrl_(controller_params(params_)), fallback_(params_.gains, params_.camera) {}

void TbzApproach::reset() {
  anchors_.clear();
  matches_.reset();
  ctrl_.reset();
  last_ = {};
  refusal_.clear();
  fallback_.reset();
  fell_back_ = false;
  refusing_since_.reset();
  no_desired_since_.reset();
  no_desired_ = false;
  started_at_.reset();
  stepped_at_.reset();
  fallback_note_.clear();
  frames_.clear();
  first_frame_.reset();
}

void TbzApproach::on_matches(const feature_matches_t& m) {
  matches_ = m;
  // Counted from the approach's start (before it the arm may be turning fast),
  // once there is a desired image to verify against.
  if (!started_at_ || m.status == feature_matches_t::STATUS_NO_DESIRED) return;
  if (!first_frame_) first_frame_ = m.header.utime;
  frames_.emplace_back(m.header.utime, m.status == feature_matches_t::STATUS_OK);
  while (frames_.front().first < m.header.utime - static_cast<rt::Micros>(params_.fallback_after_s * 1e6))
    frames_.pop_front();
}

ApproachOutput TbzApproach::update(const ApproachInput& in) {
  if (in.forward_speed || fell_back_) {  // IR guidance, or no features on this fruit: as the reconstruction approach
    ApproachOutput out = fallback_.update(in);
    out.note = fallback_note_;
    return out;
  }
  if (!started_at_) started_at_ = in.now;
  ApproachOutput out = step(in);
  if (refusal_.empty()) {
    refusing_since_.reset();
    no_desired_since_.reset();
    out.note = "teach by zooming";
    if (*out.arrived) {
      char buf[160];
      std::snprintf(buf, sizeof buf, " arrived after %.1f s (rotation error %.2f deg, translation error %.4f)",
                    rt::to_seconds(in.now - *started_at_), last_.e_w.norm() * 180.0 / M_PI, last_.e_v.norm());
      out.note += buf;
    }
    return out;
  }
  // Waiting for a desired image and refusing matches run on separate clocks:
  // the first wait does not shorten the second.
  auto& since = no_desired_ ? no_desired_since_ : refusing_since_;
  if (!since) since = in.now;
  const double refusing_s = rt::to_seconds(in.now - *since);
  // The share of verified frames, once they have been watched for fallback_after_s.
  const auto window = static_cast<rt::Micros>(params_.fallback_after_s * 1e6);
  while (!frames_.empty() && frames_.front().first < in.now - window) frames_.pop_front();
  int verified = 0;
  for (const auto& f : frames_) verified += f.second;
  const bool few_verified = !no_desired_ && first_frame_ && in.now - *first_frame_ >= window && !frames_.empty() &&
                            verified < params_.min_verified_share * static_cast<double>(frames_.size());
  if (refusing_s < (no_desired_ ? params_.desired_wait_s : params_.fallback_after_s) && !few_verified) {
    // A frame or two without matches is not news (HARVEST_STATUS goes out on every change of the note).
    out.note = refusing_s < 0.5 * params_.fallback_after_s ? "teach by zooming"
                                                           : "teach by zooming: waiting (" + refusal_ + ")";
    return out;
  }
  // The thesis's finding (section 5.7): no features to match on natural fruit. Approach it as without TBZ.
  fell_back_ = true;
  char share[96] = "";
  if (!frames_.empty())
    std::snprintf(share, sizeof share, "; %d of %zu frames verified in the last %.1f s", verified, frames_.size(),
                  params_.fallback_after_s);
  fallback_note_ =
      "teach by zooming impossible (" + refusal_ + share + "), falling back to the 3D-reconstruction approach";
  out = fallback_.update(in);
  out.note = fallback_note_;
  return out;
}

ApproachOutput TbzApproach::step(const ApproachInput& in) {
  ApproachOutput out;
  out.error.setZero();
  out.arrived = false;
  const Eigen::Matrix3d R_tool = in.tool.rotation();
  no_desired_ = matches_ && matches_->status == feature_matches_t::STATUS_NO_DESIRED;
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
  stepped_at_ = in.now;
  // With the hand-eye rotation taken from the poses the controller works in
  // the camera frame (R_r_hat = I) and its twist is rotated into the base
  // frame with the camera's orientation; otherwise with the tool's.
  const Eigen::Matrix3d R_out = params_.hand_eye_from_poses ? in.camera.rotation() : R_tool;
  out.twist.linear = R_out * last_.robot.v;
  out.twist.angular = R_out * last_.robot.w;
  out.error = last_.e_v;
  out.arrived = last_.e_w.norm() <= params_.arrived_rotation && last_.e_v.norm() <= params_.arrived_translation;
  return out;
}

}  // namespace harvest::servo
