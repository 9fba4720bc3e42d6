#include "arm/nodes.hpp"

#include "arm/robot_link_node.hpp"

namespace harvest::arm {

rt::NodeList make_robot_link(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<RobotLinkNode>(RobotLinkConfig::from_config(cfg)));
  return nodes;
}

}  // namespace harvest::arm
