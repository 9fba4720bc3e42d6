// The visual approach: a pluggable strategy that turns the latest view of the
// target fruit into a tool twist. The harvest state machine owns everything
// else (orientation, IR phase switching, limits, timeouts), so an alternative
// approach (e.g. the teach-by-zooming controller of chapter 5) only has to
// implement ApproachStrategy and be named in approach_mode.
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "runtime/clock.hpp"
#include "servo/motion_limits.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

// One centroid of the target fruit in the camera-in-hand image.
struct PixelMeasurement {
  PixelMeasurement() = default;
  PixelMeasurement(double u_px, double v_px, rt::Micros taken, std::optional<Eigen::Isometry3d> from = std::nullopt)
      : u(u_px), v(v_px), utime(taken), camera(std::move(from)) {}
  double u = 0.0, v = 0.0;  // [px], distorted, as detected
  rt::Micros utime = 0;     // when the image was taken
  // The camera-in-hand optical frame in the base frame when the image was
  // taken, if known; else the pixel is seen from the newest camera pose.
  std::optional<Eigen::Isometry3d> camera;
};

struct ApproachInput {
  rt::Micros now = 0;
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();    // tool centre point in the base frame
  Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();  // camera-in-hand optical frame in the base frame
  Eigen::Vector3d fruit_base = Eigen::Vector3d::Zero();      // best 3D estimate of the fruit centre
  std::optional<PixelMeasurement> pixel;                     // newest associated centroid, if fresh
  // Set under IR guidance: hold this forward speed along the approach axis
  // (the gripper axis for the reconstruction approach, the camera axis for
  // teach by zooming) instead of regulating the depth error (thesis HarvestStep5).
  std::optional<double> forward_speed;
  // Under IR guidance: centre on the fruit's mean position over this long (unset: gains.sway_window).
  std::optional<double> mean_window;
  // The pixel's detection is whole (clear of the image border, not filling the image): with gains.whole_views,
  // only whole views enter the mean.
  bool pixel_whole = true;
};

struct ApproachOutput {
  Twist twist;  // desired tool twist in the base frame, before limits
  // [m] centring x, y and depth error: of the fruit from the gripper axis in
  // the tool frame (reconstruction), or in the camera frame (teach by zooming).
  Eigen::Vector3d error;
  // Strategies that servo to a goal of their own (teach by zooming: the pose
  // whose view is the zoomed image) say when they are there; the machine then
  // hands over to IR guidance. Unset: the machine switches by the remaining
  // distance to the fruit (ir_switch_distance).
  std::optional<bool> arrived;
  // What the strategy is doing, for HARVEST_STATUS (shown when it changes).
  std::string note;
};

class ApproachStrategy {
 public:
  virtual ~ApproachStrategy() = default;
  virtual std::string name() const = 0;
  // Called when a new approach to a fruit starts.
  virtual void reset() = 0;
  virtual ApproachOutput update(const ApproachInput& in) = 0;
  // True: update() is asked before the remaining distance, and its `arrived` decides the switch to IR guidance.
  virtual bool has_own_goal() const { return false; }
};

// 3D-reconstruction visual servoing, eq. 6-25..6-28. The pixel errors
// (u - u0, v - v0) are turned into metric lateral errors with the undistorted
// normalised coordinates times the estimated depth, so one gain set works at
// every distance. That point is carried from the camera into the tool frame
// (the hand-eye calibration), so the fruit is centred on the gripper axis and
// the depth error is the fruit's depth ahead of the tool point along it.
// v_tool = kp e + kd de/dt, rotated into the base frame. (The thesis writes
// -kv de/dt with its error sign; here kd > 0 always damps.)
// Where the camera-in-hand sees the fruit, in the base frame: on the ray
// through the pixel, at the depth along the optical axis of the best 3D
// estimate `fruit_base` (eq. 6-15, 6-25, 6-26). The camera is where it took
// the image (pixel.camera) if known, else at `camera`.
Eigen::Vector3d seen_in_base(const geometry::CameraModel& k, const Eigen::Isometry3d& camera,
                             const PixelMeasurement& pixel, const Eigen::Vector3d& fruit_base);

class ReconstructionApproach final : public ApproachStrategy {
 public:
  ReconstructionApproach(Gains gains, geometry::CameraModel camera) : gains_(gains), camera_(camera) {}
  std::string name() const override { return "reconstruction"; }
  void reset() override;
  ApproachOutput update(const ApproachInput& in) override;

 private:
  // The fruit's base-frame position from each new hand measurement (pixel
  // ray at the estimated depth), for the mean over gains.sway_window.
  struct Seen {
    rt::Micros utime;
    Eigen::Vector3d base;
  };
  std::deque<Seen> seen_;
  Gains gains_;
  geometry::CameraModel camera_;
  std::optional<rt::Micros> last_utime_;
  Eigen::Vector3d last_error_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d error_rate_ = Eigen::Vector3d::Zero();
};

// Builds the strategy named by config.approach_mode; throws std::invalid_argument for an unknown name.
std::unique_ptr<ApproachStrategy> make_approach(const ServoConfig& config);

}  // namespace harvest::servo
