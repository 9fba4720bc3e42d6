// harvest-replay (docs/replay.md): runs chosen nodes over a log with
// rt::ReplayRunner, writes the output log, and compares the regenerated
// channels with the recorded ones.
//
//   harvest-replay LOG --node fruit-detector:config/vision/detector-fixed.yaml
//       --node fruit-detector:config/vision/detector-hand.yaml
//       --node reconstructor:config/vision/reconstructor.yaml
//       --out OUT.lcmlog --compare [--tolerance CHANNEL.field=abs] [--ignore CHANNEL.field]
//
// A node is [LABEL=]PROCESS[:CONFIG]: PROCESS is a registry name (the process
// it runs in, see --list-nodes), CONFIG its configuration file. LABEL names it
// in --set LABEL:key=value; by default it is PROCESS, or PROCESS/STEM of the
// configuration file when a process appears twice.
//
// Exit codes: 0 replayed (and, with --compare, the same as recorded),
// 1 differences, 2 bad command line or configuration, 3 replay failed.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "logtools/compare.hpp"
#include "runtime/process_main.hpp"

namespace harvest::logtools {

struct ReplayableNode {
  std::string process;  // "fruit-detector"
  rt::NodeFactory factory;
  std::string summary;
};
const std::vector<ReplayableNode>& node_registry();

struct NodeSpec {
  std::string label, process, config;
  std::string yaml;   // non-empty: the configuration itself (a CONFIG snapshot), `config` only names it
  int64_t start = 0;  // from a CONFIG snapshot: when its process started (log time); 0: at the first event
};

// A process's CONFIG snapshot as recorded in a log (config_snapshot_t).
struct LoggedConfig {
  std::string process, instance, config_path, yaml, command_line;
  int64_t log_time = 0;  // when it was recorded: the process was running and subscribed from then on
  int64_t started = 0;   // header.utime: the process's clock when it attached its nodes
  // When the process started, on the log's clock: `started` when it is a
  // plausible reading of that clock (the same host), else the log time.
  int64_t start() const {
    return started > 0 && started <= log_time && log_time - started < 1'000'000 ? started : log_time;
  }
};
// Every instance's first CONFIG snapshot on PREFIX+CONFIG, in log order.
std::vector<LoggedConfig> logged_configs(const std::string& log, const std::string& prefix = "");
// The nodes a log's own snapshots say to replay (replayable processes only).
std::vector<NodeSpec> nodes_from_configs(const std::vector<LoggedConfig>& configs);
// Throws std::invalid_argument on an unknown process name.
NodeSpec parse_node_spec(const std::string& spec);

struct ReplayToolOptions {
  std::string input_log;
  std::string output_log;              // required
  std::vector<std::string> nodes;      // empty: the nodes and configurations of the log's CONFIG snapshots
  std::vector<std::string> overrides;  // [LABEL:]key=value
  std::string prefix;
  bool compare = false;
  CompareOptions compare_options;
  double tail_s = 0;
  // Write OUT as the input with the regenerated channels replaced by the
  // replayed ones (refreshing a reference log when a change is intended).
  bool rebase = false;
  // The log's own nodes: replay each process with a JOURNAL from it (exact);
  // false: every node by the log's order and its timers' due times (approximate).
  bool use_journals = true;
};

int run_replay_tool(const ReplayToolOptions& options, std::ostream& out, std::ostream& err);

int replay_main(int argc, char** argv);

}  // namespace harvest::logtools
