#include "sim/nodes.hpp"

#include "sim/sim_node.hpp"

namespace harvest::sim {

rt::NodeList make_sim(const config::Node& cfg, const rt::ProcessEnv& /*env*/) {
  SimConfig config = SimConfig::from_config(cfg);
  Scenario scenario = load_scenario(config.scenario_path).for_run(config.run);
  if (config.seed >= 0) scenario = scenario.with_seed(static_cast<uint64_t>(config.seed));
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<SimNode>(std::move(config), std::move(scenario)));
  return nodes;
}

}  // namespace harvest::sim
