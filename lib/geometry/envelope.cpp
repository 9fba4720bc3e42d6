#include "geometry/envelope.hpp"

namespace harvest::geometry {

namespace {

Eigen::Vector3d vec3(const config::Node& n, const std::string& key) {
  const auto v = n.numbers(key, 3);
  return {v[0], v[1], v[2]};
}

}  // namespace

Envelope Envelope::from_yaml(const config::Node& n) {
  Envelope e;
  const config::Node ws = n.required_child("workspace");
  e.min = vec3(ws, "min");
  e.max = vec3(ws, "max");
  if ((e.min.array() >= e.max.array()).any()) ws.fail("max", "greater than min on every axis");
  // Floors: the robot link refuses pose goals capped below 0.01 m/s and
  // 0.02 rad/s (limits.min_goal_*_speed), so the controller's caps, which are
  // these speeds, must not be lower.
  e.max_linear_speed = n.required<double>("max_linear_speed", {0.01, 2.0});
  e.max_angular_speed = n.required<double>("max_angular_speed", {0.02, 5.0});
  e.max_linear_acceleration = n.required<double>("max_linear_acceleration", {0.01, 10.0});
  e.max_angular_acceleration = n.required<double>("max_angular_acceleration", {0.01, 20.0});
  return e;
}

Envelope Envelope::from_config(const config::Node& n, const std::string& key, const std::string& fallback) {
  const auto path = n.file_path(key, fallback);
  try {
    auto doc = config::Document::load_file(path);
    const Envelope e = from_yaml(doc.root());
    doc.check_unused();
    return e;
  } catch (const std::exception& ex) {
    n.fail(key, std::string("a readable robot envelope (") + ex.what() + ")");
  }
}

bool Envelope::contains_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
  return (lo.array() >= min.array()).all() && (hi.array() <= max.array()).all();
}

}  // namespace harvest::geometry
