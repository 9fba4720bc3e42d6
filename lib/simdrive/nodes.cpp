#include "simdrive/nodes.hpp"

#include "simdrive/sim_drives_node.hpp"

namespace harvest::simdrive {

rt::NodeList make_sim_drives(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<SimDrivesNode>(SimDrivesConfig::from_config(cfg)));
  return nodes;
}

}  // namespace harvest::simdrive
