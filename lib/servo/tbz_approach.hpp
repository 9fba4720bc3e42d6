// Teach-by-zooming approach (thesis chapter 5, docs/teach-by-zooming.md) as
// an ApproachStrategy: the tool twist comes from the uncalibrated TBZ
// controller fed with the verified correspondences of FEATURE_MATCHES
// (zoomed fixed-camera image <-> camera-in-hand image).
//
// Wiring: whoever owns the strategy forwards every feature_matches_t to
// on_matches() (the servo controller node subscribes FEATURE_MATCHES when
// approach_mode is "tbz"). Without fresh verified matches (status not OK,
// or older than max_match_age_s) the twist is zero and error zero:
// the harvest machine's own timeouts then give the fruit up.
#pragma once

#include <optional>

#include "control/tbz_controller.hpp"
#include "harvest/feature_matches_t.hpp"
#include "servo/approach.hpp"

namespace harvest::servo {

struct TbzApproachParams {
  control::TbzParams controller;    // A_hat: the hand camera's intrinsics estimate
  bool hand_eye_from_poses = true;  // true: ignore controller.R_r_hat, rotate with the camera pose
  double max_match_age_s = 0.3;
  // Under IR guidance (forward_speed set) TBZ hands over: only the forward speed.
};

// Defaults for the servo configuration: A_hat from the hand camera intrinsics.
TbzApproachParams tbz_params_from(const ServoConfig& config);

class TbzApproach final : public ApproachStrategy {
 public:
  explicit TbzApproach(TbzApproachParams params);
  std::string name() const override { return "tbz"; }
  void reset() override;
  ApproachOutput update(const ApproachInput& in) override;
  void on_matches(const feature_matches_t& matches);
  // Why the last update commanded no motion ("" when it moved).
  const std::string& last_refusal() const { return refusal_; }
  const control::TbzOutput& last_output() const { return last_; }

 private:
  TbzApproachParams params_;
  control::TbzController ctrl_;
  std::optional<feature_matches_t> matches_;
  geometry::Points2 anchors_;
  control::TbzOutput last_;
  std::string refusal_;
};

}  // namespace harvest::servo
