#include "geometry/envelope.hpp"

namespace harvest::geometry {

namespace {

Eigen::Vector3d vec3(const config::Node& n, const config::Numbers& key) {
  const auto v = n.get(key);
  return {v[0], v[1], v[2]};
}

}  // namespace

Envelope Envelope::from_yaml(const config::Node& n) {
  namespace k = envelope_keys;
  Envelope e;
  const config::Node ws = n.required_child("workspace");
  e.min = vec3(ws, k::workspace_min);
  e.max = vec3(ws, k::workspace_max);
  if ((e.min.array() >= e.max.array()).any()) ws.fail("max", "greater than min on every axis");
  e.max_linear_speed = n.get(k::max_linear_speed);
  e.max_angular_speed = n.get(k::max_angular_speed);
  e.max_linear_acceleration = n.get(k::max_linear_acceleration);
  e.max_angular_acceleration = n.get(k::max_angular_acceleration);
  return e;
}

std::vector<config::Section> Envelope::schema() {
  namespace k = envelope_keys;
  const std::string where = "The robot envelope file (config/arm/envelope.yaml), read by the robot link and the servo "
                            "controller; every key is required.";
  return {config::section("envelope", where, k::max_linear_speed, k::max_angular_speed, k::max_linear_acceleration,
                          k::max_angular_acceleration),
          config::section("envelope.workspace", where, k::workspace_min, k::workspace_max)};
}

Envelope Envelope::from_config(const config::Node& n, const config::Key<config::Path>& key_decl) {
  const std::string key = key_decl.name;
  const auto path = n.get(key_decl);
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
