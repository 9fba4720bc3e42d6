// Publishes the process's configuration once at start (CONFIG) and a
// heartbeat with the health and counters of its nodes at 1 Hz
// (PROCESS_STATUS). Added by run_process to every process.
#pragma once

#include <string>
#include <vector>

#include "runtime/node.hpp"

namespace harvest::rt {

struct ProcessIdentity {
  std::string process;       // executable name, e.g. "fruit-detector"
  std::string instance;      // instance name, e.g. "detector-fixed"
  std::string host;
  int pid = 0;
  std::string config_path;
  std::string config_yaml;   // effective configuration
  std::string command_line;
  std::string version;
};

class HeartbeatNode final : public Node {
 public:
  HeartbeatNode(ProcessIdentity id, std::vector<const Node*> watched, Micros period = kSecond);
  void begin_shutdown() override;

 private:
  void on_attach() override;
  void beat();

  ProcessIdentity id_;
  std::vector<const Node*> watched_;
  Micros period_;
  Micros start_ = 0;
  bool stopping_ = false;
};

}  // namespace harvest::rt
