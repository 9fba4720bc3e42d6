// The main() shared by every process: command line, logging, configuration,
// signals, heartbeat and the live runner. A process's main is a few lines:
//
//   int main(int argc, char** argv) {
//     return harvest::rt::run_process(argc, argv, "fruit-detector",
//         [](const harvest::config::Node& cfg, harvest::rt::ProcessEnv& env) {
//           std::vector<std::unique_ptr<harvest::rt::Node>> nodes;
//           nodes.push_back(std::make_unique<DetectorNode>(DetectorConfig::from_yaml(cfg)));
//           return nodes;
//         });
//   }
//
// Command line (every process):
//   --config FILE     YAML configuration (default: none, all defaults)
//   --set KEY=VALUE   override one configuration value (repeatable)
//   --lcm-url URL     LCM provider URL (default: $LCM_DEFAULT_URL or LCM's default)
//   --prefix P        channel prefix, so two arms can share one network
//   --instance NAME   instance name in heartbeats and logs (default: process name)
//   --log-level L     trace, debug, info, warn, error (default: info)
//   --check-config    validate the configuration, print it, exit
//   --no-netcheck     skip the network self-check
// Exit codes: 0 clean stop, 1 runtime failure, 2 bad command line or configuration.
//
// The factory only builds nodes from configuration; it must not touch
// hardware. Devices are opened in Node::on_attach(), which runs only after the
// whole configuration (unknown keys included) has been validated, so a
// process with bad configuration exits before it moves anything.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "runtime/node.hpp"

namespace CLI {
class App;
}

namespace harvest::rt {

struct ProcessEnv {
  std::string process;
  std::string instance;
  std::string lcm_url;
  std::string prefix;
};

using NodeList = std::vector<std::unique_ptr<Node>>;
using NodeFactory = std::function<NodeList(const config::Node& root, const ProcessEnv& env)>;

struct ProcessOptions {
  std::string description;
  // Extra command-line options; their values must be read in the factory.
  std::function<void(CLI::App&)> add_options;
};

int run_process(int argc, char** argv, const std::string& process, const NodeFactory& make,
                const ProcessOptions& options = {});

// Load a configuration file (or an empty one) and apply overrides; shared by
// run_process and the offline tools. Throws config::Error.
config::Document load_config(const std::string& path, const std::vector<std::string>& overrides);

std::string software_version();

}  // namespace harvest::rt
