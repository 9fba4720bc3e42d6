// Follows the current fruit in the camera-in-hand image: which detection is
// it (association), is it whole (its apparent size gives a depth), where its
// ray crosses the fixed camera's line of sight, and what the reconstructor's
// hand target for it says (the new estimate, eq. 6-15). Also watches for a
// nearer fruit filling the view on the gripper axis (the IR then reads that
// fruit).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <utility>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/approach.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class HandTracker {
 public:
  explicit HandTracker(ServoConfig config) : cfg_(std::move(config)) {}

  // A new fruit (or none): forget the followed detection and the
  // reconstructor's pixel for it.
  void forget_fruit() {
    pixel_.reset();
    hand_target_px_.reset();
  }

  // A FRUIT_HAND message while following `fruit`, its image taken by the camera at `camera`.
  void on_detections(const fruit_detections_t& msg, const Fruit& fruit, const Eigen::Isometry3d& camera,
                     rt::Micros now);
  // A hand-camera TARGETS message: remembers the pixel of the target with the
  // fruit's id, and re-estimates the fruit from the target made from the
  // followed detection (same image, same pixel) if that detection was whole,
  // checked against the rays' crossing.
  void on_hand_targets(const targets_t& msg, Fruit& fruit, const Eigen::Isometry3d& camera, rt::Micros now);

  // The followed centroid, if seen within timeouts.lost.
  std::optional<PixelMeasurement> fresh(rt::Micros now) const;
  // When the followed centroid was last updated (receive time).
  rt::Micros seen_at() const { return pixel_rx_; }
  // The followed detection is the whole fruit (clear of the image border, not filling the image): its centroid is
  // the fruit's centre.
  bool whole() const { return pixel_whole_; }
  // A fruit nearer than the current one filled the view on the gripper axis
  // within timeouts.lost: how far its centre lies off the axis [m].
  std::optional<double> fruit_in_front(rt::Micros now) const;
  // The followed fruit is whole in a hand image no older than far_view_age: its apparent size is a depth, taken
  // now (ServoConfig::far_view_ahead).
  bool seen_whole(rt::Micros now) const;
  // A fruit covered the image centre and axis_fruit_area of a hand image no older than far_view_age: what the IR
  // reads at the grasp range then is a fruit, not a leaf (whichever fruit: the followed one, its estimate too deep,
  // or a nearer one).
  bool fruit_on_axis(rt::Micros now) const;

 private:
  // The current fruit where the camera-in-hand's ray through `pixel` crosses
  // the fixed camera's line of sight; nullopt if they do not cross closely
  // at a useful angle (another fruit, or a line of sight too poor).
  std::optional<Eigen::Vector3d> cross(const PixelMeasurement& pixel, const Fruit& fruit,
                                       const Eigen::Isometry3d& camera) const;

  // The point of the camera-in-hand's ray through `pixel` nearest the fixed
  // camera's estimate `fixed`, if the ray passes within fixed_depth_gap of it
  // and the point lies in the workspace.
  std::optional<Eigen::Vector3d> along_ray(const PixelMeasurement& pixel, const Eigen::Vector3d& fixed,
                                           const Eigen::Isometry3d& camera) const;
  // The unit ray (base frame) through an undistorted pixel of the camera at `camera`.
  Eigen::Vector3d ray_through(const PixelMeasurement& pixel, const Eigen::Isometry3d& camera) const;

  ServoConfig cfg_;
  std::optional<PixelMeasurement> pixel_;  // associated centroid of the current fruit
  rt::Micros pixel_rx_ = 0;
  float pixel_diameter_ = 0.0f;                                     // ... its apparent diameter [px]
  Eigen::Isometry3d pixel_camera_ = Eigen::Isometry3d::Identity();  // ... the camera that took it
  bool pixel_whole_ = false;                       // ... the whole fruit, inside the image: its size gives a depth
  std::optional<Eigen::Vector3d> pixel_crossing_;  // ... where its ray crosses the fixed camera's line of sight
  rt::Micros fruit_fills_view_rx_ = 0;  // last hand image with a fruit filling it on the gripper axis (0: none)
  double fruit_in_front_offset_ = 0.0;  // ... its centre's distance from the gripper axis [m]
  std::optional<rt::Micros> fruit_on_axis_taken_;  // capture time of the last hand image a fruit covered on its centre
  std::optional<Eigen::Vector2d> hand_target_px_;  // pixel of the hand target the reconstructor gave the current id
  rt::Micros hand_target_rx_ = 0;
};

}  // namespace harvest::servo
