// Teach-by-zooming approach (thesis chapter 5, docs/teach-by-zooming.md) as
// an ApproachStrategy: the tool twist comes from the uncalibrated TBZ
// controller fed with the verified correspondences of FEATURE_MATCHES
// (zoomed fixed-camera image <-> camera-in-hand image).
//
// Wiring: whoever owns the strategy forwards every feature_matches_t to
// on_matches() (the servo controller node subscribes FEATURE_MATCHES when
// approach_mode is "tbz"). Without fresh verified matches (status not OK,
// or older than max_match_age_s) the twist is zero and error zero; when that
// lasts fallback_after_s (natural fruit: no features, the thesis's finding
// in section 5.7; or no zoomed view of this fruit; without any desired image
// yet, desired_wait_s) the approach to this fruit
// falls back to the 3D-reconstruction approach and says so in its note.
// TBZ servos to a pose of its own (the view of the zoomed image) and reports
// `arrived` when its rotation and translation errors are within the
// thresholds; IR guidance is then the reconstruction approach's (centring
// the fruit on the gripper axis), as after any approach.
#pragma once

#include <deque>
#include <optional>

#include "control/tbz_controller.hpp"
#include "harvest/feature_matches_t.hpp"
#include "servo/approach.hpp"

namespace harvest::servo {

// The TBZ errors of each step, for plots of the thesis's figures 5-5, 5-6
// (tools/plot_log.py): twist_t with linear = e_v (eq. 5-55) and angular =
// e_w = u theta (eq. 5-40), published by the servo controller on each tick
// that stepped the TBZ controller.
inline constexpr const char* kTbzErrorChannel = "TBZ_ERROR";

struct TbzApproachParams {
  control::TbzParams controller;    // A_hat: the hand camera's intrinsics estimate
  bool hand_eye_from_poses = true;  // true: ignore controller.R_r_hat, rotate with the camera pose
  // As ServoConfig::Tbz: |e_w| is u theta, |e_v| normalised pixels and the log depth ratio (eq. 5-55).
  double max_match_age_s = 0.3;
  double fallback_after_s = 1.5;
  // A verified frame now and then does not make a target: spurious matches
  // (leaves, a silhouette) verify sporadically. Also fall back when fewer than
  // this share of the FEATURE_MATCHES of the last fallback_after_s were
  // verified (a stickered fruit: 86-100 %; docs/teach-by-zooming.md).
  double min_verified_share = 0.5;
  // Without a desired image there is nothing to match yet, no sign that the
  // fruit lacks features: the zoomed view comes at the zoom camera's rate (0.5
  // Hz in the simulator, its first frame 2 s after start), and a controller in
  // APPROACH sooner waits for it this long instead of fallback_after_s.
  double desired_wait_s = 5.0;
  double arrived_rotation = 0.0175;
  double arrived_translation = 0.01;
  // Under IR guidance (forward_speed set) and after a fallback: the reconstruction approach.
  Gains gains;
  geometry::CameraModel camera;
};

// Defaults for the servo configuration: A_hat from the hand camera intrinsics.
TbzApproachParams tbz_params_from(const ServoConfig& config);

class TbzApproach final : public ApproachStrategy {
 public:
  explicit TbzApproach(TbzApproachParams params);
  std::string name() const override { return "tbz"; }
  void reset() override;
  ApproachOutput update(const ApproachInput& in) override;
  bool has_own_goal() const override { return true; }
  void on_matches(const feature_matches_t& matches);
  // This fruit is approached by 3D reconstruction (no usable matches for fallback_after_s).
  bool fell_back() const { return fell_back_; }
  // When the TBZ controller last stepped (its errors are last_output()'s).
  const std::optional<rt::Micros>& stepped_at() const { return stepped_at_; }
  // Why the last update commanded no motion ("" when it moved).
  const std::string& last_refusal() const { return refusal_; }
  const control::TbzOutput& last_output() const { return last_; }

 private:
  ApproachOutput step(const ApproachInput& in);  // one TBZ step; refusal_ says why it did not move

  TbzApproachParams params_;
  control::TbzController ctrl_;
  std::optional<feature_matches_t> matches_;
  geometry::Points2 anchors_;
  control::TbzOutput last_;
  std::string refusal_;
  bool no_desired_ = false;  // the refusal is STATUS_NO_DESIRED
  ReconstructionApproach fallback_;
  bool fell_back_ = false;
  std::optional<rt::Micros> refusing_since_, no_desired_since_, started_at_, stepped_at_;
  // FEATURE_MATCHES with a desired image since the approach started:
  // (utime, verified) of the last fallback_after_s, and the first one's utime.
  std::deque<std::pair<rt::Micros, bool>> frames_;
  std::optional<rt::Micros> first_frame_;
  std::string fallback_note_;
};

}  // namespace harvest::servo
