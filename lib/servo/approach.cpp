#include "servo/approach.hpp"

#include <algorithm>
#include <stdexcept>

#include "servo/geometry.hpp"
#include "servo/tbz_approach.hpp"

namespace harvest::servo {

Eigen::Vector3d seen_in_base(const geometry::CameraModel& k, const Eigen::Isometry3d& camera,
                             const PixelMeasurement& pixel, const Eigen::Vector3d& fruit_base) {
  const Eigen::Isometry3d& cam = pixel.camera ? *pixel.camera : camera;
  // Depth of the fruit along the optical axis from the best 3D estimate (eq. 6-15); eq. 6-25, 6-26 in
  // normalised coordinates, scaled by it: the fruit in the camera frame.
  const double depth = std::max(0.0, (cam.rotation().transpose() * (fruit_base - cam.translation())).z());
  const Eigen::Vector2d m = undistort_pixel(k, pixel.u, pixel.v);
  return cam * Eigen::Vector3d(m.x() * depth, m.y() * depth, depth);
}

void ReconstructionApproach::reset() {
  seen_.clear();
  last_utime_.reset();
  last_error_.setZero();
  error_rate_.setZero();
}

ApproachOutput ReconstructionApproach::update(const ApproachInput& in) {
  // The fruit is brought onto the gripper axis (tool z), not onto the
  // camera's optical axis: the camera sits beside the gripper axis and a few
  // degrees off parallel, and the hand-eye calibration (camera pose vs tool
  // pose, both from ROBOT_STATE) carries its measurement into the tool frame.
  // With the camera at the tool point, looking along its axis, this is
  // eq. 6-25..6-28 as the thesis writes them.
  const Eigen::Isometry3d tool_inv = in.tool.inverse();
  // Without a fresh view nothing lateral is known: only the depth along the gripper axis.
  Eigen::Vector3d e(0.0, 0.0, std::max(0.0, (tool_inv * in.fruit_base).z()));
  if (in.pixel) {
    // The fruit seen, in the base frame, then in the tool frame.
    const Eigen::Vector3d seen_base = seen_in_base(camera_, in.camera, *in.pixel, in.fruit_base);
    e = tool_inv * seen_base;
    const double window = in.mean_window.value_or(gains_.sway_window);
    if (in.forward_speed && window > 0.0) {
      // Under IR guidance (near the fruit, centred, its depth good): the mean
      // of its positions over the window, seen from the tool now. Earlier
      // views are left out: far off the image centre, their depth error moves
      // them sideways.
      // With whole_views a fruit cut by the image border or filling it (the last centimetres) is not centred on:
      // the detector's centre of its visible part lies toward the image centre, up to a fruit's radius off; the
      // whole views before it stay the mean, counted back from the newest of them.
      const bool enters = in.pixel_whole || !gains_.whole_views;
      if (enters && (seen_.empty() || in.pixel->utime > seen_.back().utime))
        seen_.push_back({in.pixel->utime, seen_base});
      if (!seen_.empty()) {
        while (seen_.front().utime < seen_.back().utime - rt::from_seconds(window)) seen_.pop_front();
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& s : seen_) mean += s.base;
        const Eigen::Vector3d q = tool_inv * (mean / static_cast<double>(seen_.size()));
        e.x() = q.x();
        e.y() = q.y();
      }
    }
    // Derivative only from new measurements, low-pass filtered (images are noisy).
    if (last_utime_ && in.pixel->utime > *last_utime_) {
      const double dt = rt::to_seconds(in.pixel->utime - *last_utime_);
      const Eigen::Vector3d rate = (e - last_error_) / dt;
      error_rate_ = gains_.derivative_filter * rate + (1.0 - gains_.derivative_filter) * error_rate_;
    }
    if (!last_utime_ || in.pixel->utime > *last_utime_) {
      last_utime_ = in.pixel->utime;
      last_error_ = e;
    }
  }
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (in.pixel) {
    v.x() = gains_.kp_lateral * e.x() + gains_.kd_lateral * error_rate_.x();
    v.y() = gains_.kp_lateral * e.y() + gains_.kd_lateral * error_rate_.y();
  }
  // Eq. 6-27, 6-28 along the axis, or the constant IR-guided speed.
  v.z() = in.forward_speed ? *in.forward_speed : gains_.kp_depth * e.z() + gains_.kd_depth * error_rate_.z();
  // ... but no faster than the centring converges: the lateral error decays
  // as exp(-kp t), so arriving centred within the tolerance takes at least
  // ln(error / tolerance) / kp. A gripper that outruns its centring arrives
  // beside the fruit, closes on nothing and its fingers or palm knock
  // neighbours off.
  const double lateral = e.head<2>().norm();
  if (in.pixel && gains_.kp_lateral > 0.0 && gains_.centring_tolerance > 0.0 && lateral > gains_.centring_tolerance)
    v.z() = std::min(v.z(), gains_.kp_lateral * std::max(0.0, e.z()) / std::log(lateral / gains_.centring_tolerance));
  ApproachOutput out;
  out.twist.linear = in.tool.rotation() * v;
  out.error = e;
  return out;
}

std::unique_ptr<ApproachStrategy> make_approach(const ServoConfig& config) {
  if (config.approach_mode == "reconstruction")
    return std::make_unique<ReconstructionApproach>(config.gains, config.hand_camera);
  if (config.approach_mode == "tbz") return std::make_unique<TbzApproach>(tbz_params_from(config));
  throw std::invalid_argument("unknown approach_mode '" + config.approach_mode + "'");
}

}  // namespace harvest::servo
