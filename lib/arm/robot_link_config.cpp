#include "arm/robot_link_config.hpp"

#include <string>

#include "geometry/envelope.hpp"

namespace harvest::arm {

RobotLinkConfig RobotLinkConfig::from_config(const config::Node& root) {
  RobotLinkConfig c;
  c.bus = canopen::bus_from_config(root, "bus", c.bus);
  c.model = kinematics::ArmModel::load(root.file_path("arm_model", "k1207i.yaml").string());
  c.can = canopen::MasterConfig::from_config(root.child("can"));
  if (static_cast<int>(c.can.drives.size()) != c.model.dof())
    root.child("can").fail("drives", "one drive per joint of the arm model (" + std::to_string(c.model.dof()) + ")");
  // The drives' own quick-stop ramp (written as 0x6085): what stops the arm
  // when the link is gone, so it is ours to set, not the drive vendor's.
  const double quick_stop = root.child("can").get<double>("quick_stop_deceleration_factor", 10.0, {0.5, 50.0});
  for (std::size_t i = 0; i < c.can.drives.size(); ++i)
    c.can.drives[i].quick_stop_deceleration = quick_stop * c.model.joints[i].max_acceleration;
  // Workspace and speed/acceleration limits: the envelope the controller also reads.
  const auto envelope = geometry::Envelope::from_config(root, "envelope", "envelope.yaml");
  c.limits.linear_speed = envelope.max_linear_speed;
  c.limits.angular_speed = envelope.max_angular_speed;
  c.limits.linear_acceleration = envelope.max_linear_acceleration;
  c.limits.angular_acceleration = envelope.max_angular_acceleration;
  c.workspace.min = envelope.min;
  c.workspace.max = envelope.max;
  const auto lim = root.child("limits");
  c.limits.default_validity = lim.get<int>("default_validity_ms", 100, {10, 1000}) * 1000;
  c.limits.max_validity = lim.get<int>("max_validity_ms", 1000, {10, 10000}) * 1000;
  if (c.limits.default_validity > c.limits.max_validity)
    lim.fail("default_validity_ms",
             "a validity no longer than max_validity_ms (" + std::to_string(c.limits.max_validity / 1000) + " ms)");
  c.command_limits.min_goal_linear_speed =
      lim.get<double>("min_goal_linear_speed", c.command_limits.min_goal_linear_speed, {1e-4, 0.1});
  c.command_limits.min_goal_angular_speed =
      lim.get<double>("min_goal_angular_speed", c.command_limits.min_goal_angular_speed, {1e-4, 0.5});
  c.command_limits.non_physical_factor =
      lim.get<double>("non_physical_factor", c.command_limits.non_physical_factor, {1.0, 100.0});
  if (c.command_limits.min_goal_linear_speed > c.limits.linear_speed)
    lim.fail("min_goal_linear_speed", "a speed no greater than the envelope's max_linear_speed");
  if (c.command_limits.min_goal_angular_speed > c.limits.angular_speed)
    lim.fail("min_goal_angular_speed", "a speed no greater than the envelope's max_angular_speed");
  const auto ctl = root.child("control");
  c.position_gain = ctl.get<double>("position_gain", 5.0, {0.0, 100.0});
  c.orientation_gain = ctl.get<double>("orientation_gain", 5.0, {0.0, 100.0});
  c.joint_gain = ctl.get<double>("joint_gain", 5.0, {0.0, 100.0});
  c.enable_timeout = ctl.get<int>("enable_timeout_ms", 3000, {100, 60000}) * 1000;
  c.realtime_priority = ctl.get<int>("realtime_priority", 0, {0, 99});
  c.authority = security::AuthorityConfig::from_config(root.child("authority"), security::AuthorityConfig::kController);
  return c;
}

}  // namespace harvest::arm
