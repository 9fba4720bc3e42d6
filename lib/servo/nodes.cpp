#include "servo/nodes.hpp"

#include "servo/controller_node.hpp"

namespace harvest::servo {

rt::NodeList make_servo_controller(const config::Node& cfg, const rt::ProcessEnv& env) {
  rt::NodeList nodes;
  auto authority = security::AuthorityConfig::from_config(cfg.child("authority"), security::AuthorityConfig::kSender);
  nodes.push_back(std::make_unique<ServoControllerNode>(ServoConfig::from_yaml(cfg), std::move(authority),
                                                        env.instance.empty() ? "servo-controller" : env.instance));
  return nodes;
}

}  // namespace harvest::servo
