#include "arm/robot_link_config.hpp"

#include <string>

#include "geometry/envelope.hpp"

namespace harvest::arm {

RobotLinkConfig RobotLinkConfig::from_config(const config::Node& root) {
  namespace k = link_keys;
  RobotLinkConfig c;
  c.bus = canopen::bus_from_config(root, canopen::kBusKey);
  c.model = kinematics::ArmModel::load(root.get(k::arm_model).string());
  // The model is the arm's type, shared by every robot of it; where this robot's camera-in-hand sits is its own
  // calibration (docs/calibration.md), kept beside the robot's other site files.
  if (!root.get<std::string>(k::hand_eye.name, "").empty())
    c.model.place_camera(root, k::hand_eye.name, root.get(k::hand_eye));
  c.can = canopen::MasterConfig::from_config(root.child("can"));
  if (static_cast<int>(c.can.drives.size()) != c.model.dof())
    root.child("can").fail("drives", "one drive per joint of the arm model (" + std::to_string(c.model.dof()) + ")");
  // The drives' own quick-stop ramp (written as 0x6085): what stops the arm
  // when the link is gone, so it is ours to set, not the drive vendor's.
  const double quick_stop = root.child("can").get(k::quick_stop_deceleration_factor);
  for (std::size_t i = 0; i < c.can.drives.size(); ++i)
    c.can.drives[i].quick_stop_deceleration = quick_stop * c.model.joints[i].max_acceleration;
  // Workspace and speed/acceleration limits: the envelope the controller also reads.
  const auto envelope = geometry::Envelope::from_config(root, k::envelope);
  c.limits.linear_speed = envelope.max_linear_speed;
  c.limits.angular_speed = envelope.max_angular_speed;
  c.limits.linear_acceleration = envelope.max_linear_acceleration;
  c.limits.angular_acceleration = envelope.max_angular_acceleration;
  c.workspace.min = envelope.min;
  c.workspace.max = envelope.max;
  const auto lim = root.child("limits");
  c.limits.default_validity = lim.get(k::default_validity_ms) * 1000;
  c.limits.max_validity = lim.get(k::max_validity_ms) * 1000;
  if (c.limits.default_validity > c.limits.max_validity)
    lim.fail("default_validity_ms",
             "a validity no longer than max_validity_ms (" + std::to_string(c.limits.max_validity / 1000) + " ms)");
  c.command_limits.min_goal_linear_speed = lim.get(k::min_goal_linear_speed);
  c.command_limits.min_goal_angular_speed = lim.get(k::min_goal_angular_speed);
  c.command_limits.non_physical_factor = lim.get(k::non_physical_factor);
  if (c.command_limits.min_goal_linear_speed > c.limits.linear_speed)
    lim.fail("min_goal_linear_speed", "a speed no greater than the envelope's max_linear_speed");
  if (c.command_limits.min_goal_angular_speed > c.limits.angular_speed)
    lim.fail("min_goal_angular_speed", "a speed no greater than the envelope's max_angular_speed");
  const auto ctl = root.child("control");
  c.position_gain = ctl.get(k::position_gain);
  c.orientation_gain = ctl.get(k::orientation_gain);
  c.joint_gain = ctl.get(k::joint_gain);
  c.enable_timeout = ctl.get(k::enable_timeout_ms) * 1000;
  c.realtime_priority = ctl.get(k::realtime_priority);
  c.authority = security::AuthorityConfig::from_config(root.child("authority"), security::AuthorityConfig::kController);
  return c;
}

std::vector<config::Section> RobotLinkConfig::schema() {
  namespace k = link_keys;
  const std::string where = "harvest-robot-link, config/arm/robot_link.yaml (docs/robot-link.md).";
  std::vector<config::Section> out{
      config::section("robot_link", where, canopen::kBusKey, k::arm_model, k::hand_eye, k::envelope)};
  for (auto& s : canopen::MasterConfig::schema("robot_link.can", where)) out.push_back(std::move(s));
  out[1].keys.push_back(config::describe(k::quick_stop_deceleration_factor));
  out.push_back(config::section("robot_link.limits", where, k::default_validity_ms, k::max_validity_ms,
                                k::min_goal_linear_speed, k::min_goal_angular_speed, k::non_physical_factor));
  out.push_back(config::section("robot_link.control", where, k::position_gain, k::orientation_gain, k::joint_gain,
                                k::enable_timeout_ms, k::realtime_priority));
  out.push_back(
      security::AuthorityConfig::schema("robot_link.authority", where, security::AuthorityConfig::kController));
  return out;
}

}  // namespace harvest::arm
