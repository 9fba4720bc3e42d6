// The robot's envelope: the box the tool centre point may occupy and the
// Cartesian speed and acceleration limits, in one file (config/arm/envelope.yaml)
// read by the robot link, which enforces it, and by the servo controller, which
// plans inside it. One file so the two cannot disagree: a controller aiming at
// goals the link refuses would fail every pick at the boundary.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"

namespace harvest::geometry {

// The envelope file's keys, all required: the envelope has one source, so no
// reader supplies a default.
namespace envelope_keys {
using config::Key;
using config::Numbers;
inline constexpr Numbers workspace_min{.name = "min", .size = 3, .unit = "m",
                                       .doc = "tool centre point box, lower corner (base frame)", .required = true};
inline constexpr Numbers workspace_max{.name = "max", .size = 3, .unit = "m",
                                       .doc = "upper corner, greater than min on every axis", .required = true};
// Floors: the robot link refuses pose goals capped below 0.01 m/s and
// 0.02 rad/s (limits.min_goal_*_speed), so the controller's caps, which are
// these speeds, must not be lower.
inline constexpr Key<double> max_linear_speed{.name = "max_linear_speed", .range = {0.01, 2.0}, .unit = "m/s",
                                              .doc = "tool speed limit (thesis: 15 in/s = 0.381)", .required = true};
inline constexpr Key<double> max_angular_speed{.name = "max_angular_speed", .range = {0.02, 5.0}, .unit = "rad/s",
                                               .doc = "tool angular speed limit (thesis: pi/2)", .required = true};
inline constexpr Key<double> max_linear_acceleration{.name = "max_linear_acceleration", .range = {0.01, 10.0},
                                                     .unit = "m/s^2",
                                                     .doc = "goal trajectories; the controller's twist limit",
                                                     .required = true};
inline constexpr Key<double> max_angular_acceleration{.name = "max_angular_acceleration", .range = {0.01, 20.0},
                                                      .unit = "rad/s^2",
                                                      .doc = "goal trajectories; the controller's twist limit",
                                                      .required = true};
}  // namespace envelope_keys

struct Envelope {
  Eigen::Vector3d min{-0.9, 0.3, -1.1};   // [m] tool centre point box, base frame
  Eigen::Vector3d max{0.7, 1.3, 0.3};     // [m]
  double max_linear_speed = 0.381;        // [m/s] thesis: 15 in/s
  double max_angular_speed = 1.5708;      // [rad/s] thesis: pi/2 (HarvestStep4/5)
  double max_linear_acceleration = 1.0;   // [m/s^2]
  double max_angular_acceleration = 3.0;  // [rad/s^2]

  // The file's keys (workspace.min/max, max_linear_speed, ...), all required:
  // the envelope has one source, so no reader supplies a default.
  static Envelope from_yaml(const config::Node& n);
  // from_yaml() of the file named by config key `key` (relative to the config
  // file; `fallback` if absent). Unknown keys in the envelope file are refused.
  static Envelope from_config(const config::Node& n, const config::Key<config::Path>& key);
  static std::vector<config::Section> schema();

  // Whether the box [lo, hi] lies inside this envelope's box.
  bool contains_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const;
};

}  // namespace harvest::geometry
