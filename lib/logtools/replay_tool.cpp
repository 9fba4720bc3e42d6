#include "logtools/replay_tool.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>

#include "config/config.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "servo/nodes.hpp"
#include "vision/detector_node.hpp"
#include "vision/reconstructor_node.hpp"
#ifdef HARVEST_HAVE_FEATURE_TRACKER
#include "features/nodes.hpp"
#endif

namespace harvest::logtools {

const std::vector<ReplayableNode>& node_registry() {
  static const std::vector<ReplayableNode> r = {
      {"fruit-detector", vision::make_fruit_detector, "CAMERA_* -> FRUIT_* (camera: fixed|hand in its config)"},
      {"reconstructor", vision::make_reconstructor, "FRUIT_FIXED, FRUIT_HAND, ROBOT_STATE, HARVEST_STATUS -> TARGETS"},
      {"servo-controller", servo::make_servo_controller,
       "TARGETS, FRUIT_HAND, ROBOT_STATE, IR_RANGE, GRIPPER_STATE, OPERATOR_COMMAND -> ROBOT_COMMAND, GRIPPER_COMMAND, "
       "HARVEST_STATUS"},
#ifdef HARVEST_HAVE_FEATURE_TRACKER
      {"feature-tracker", features::make_feature_tracker, "CAMERA_HAND -> FEATURES_HAND"},
#endif
  };
  return r;
}

NodeSpec parse_node_spec(const std::string& spec) {
  NodeSpec s;
  std::string rest = spec;
  auto eq = rest.find('=');
  auto colon = rest.find(':');
  if (eq != std::string::npos && (colon == std::string::npos || eq < colon)) {
    s.label = rest.substr(0, eq);
    rest = rest.substr(eq + 1);
    colon = rest.find(':');
  }
  s.process = rest.substr(0, colon);
  if (colon != std::string::npos) s.config = rest.substr(colon + 1);
  const auto& reg = node_registry();
  if (std::none_of(reg.begin(), reg.end(), [&](const ReplayableNode& n) { return n.process == s.process; })) {
    std::string names;
    for (const auto& n : reg) names += (names.empty() ? "" : ", ") + n.process;
    throw std::invalid_argument("--node '" + spec + "': no replayable node '" + s.process + "' (known: " + names + ")");
  }
  return s;
}

namespace {

struct BuiltNode {
  NodeSpec spec;
  config::Document doc;
  rt::NodeList nodes;
};

std::vector<std::string> sorted_channels(const std::set<std::string>& s) { return {s.begin(), s.end()}; }

}  // namespace

int run_replay_tool(const ReplayToolOptions& o, std::ostream& out, std::ostream& err) {
  // ---- configuration: everything is checked before the log is touched ----
  std::vector<std::unique_ptr<BuiltNode>> built;
  std::function<std::vector<std::unique_ptr<BuiltNode>>()> build;
  try {
    if (o.nodes.empty()) throw std::invalid_argument("no --node given (see --list-nodes)");
    std::vector<NodeSpec> specs;
    std::map<std::string, int> per_process;
    for (const auto& n : o.nodes) {
      specs.push_back(parse_node_spec(n));
      ++per_process[specs.back().process];
    }
    std::set<std::string> labels;
    for (auto& s : specs) {
      if (s.label.empty()) {
        s.label = s.process;
        if (per_process[s.process] > 1 && !s.config.empty())
          s.label += "/" + std::filesystem::path(s.config).stem().string();
      }
      if (!labels.insert(s.label).second)
        throw std::invalid_argument("two nodes are labelled '" + s.label +
                                    "': name them with --node LABEL=PROCESS[:CONFIG]");
    }
    std::map<std::string, std::vector<std::string>> overrides;
    for (const auto& ov : o.overrides) {
      const auto colon = ov.find(':');
      const auto eq = ov.find('=');
      if (colon != std::string::npos && (eq == std::string::npos || colon < eq)) {
        const std::string label = ov.substr(0, colon);
        if (!labels.count(label)) {
          std::string known;
          for (const auto& l : labels) known += (known.empty() ? "" : ", ") + l;
          throw std::invalid_argument("--set '" + ov + "': no node labelled '" + label + "' (nodes: " + known + ")");
        }
        overrides[label].push_back(ov.substr(colon + 1));
      } else if (specs.size() == 1) {
        overrides[specs.front().label].push_back(ov);
      } else {
        throw std::invalid_argument("--set '" + ov + "': several nodes, write --set LABEL:key=value");
      }
    }
    build = [specs, overrides, prefix = o.prefix]() {
      std::vector<std::unique_ptr<BuiltNode>> nodes;
      for (const auto& s : specs) {
        const auto ov = overrides.count(s.label) ? overrides.at(s.label) : std::vector<std::string>{};
        auto b = std::make_unique<BuiltNode>(BuiltNode{s, rt::load_config(s.config, ov), {}});
        rt::ProcessEnv env{s.process, s.label, "", prefix};
        const auto& reg = node_registry();
        auto it = std::find_if(reg.begin(), reg.end(), [&](const ReplayableNode& n) { return n.process == s.process; });
        b->nodes = it->factory(b->doc.root(), env);
        b->doc.check_unused();
        nodes.push_back(std::move(b));
      }
      return nodes;
    };
    built = build();
  } catch (const std::exception& e) {
    err << "harvest-replay: " << e.what() << "\n";
    return 2;
  }

  // ---- replay ----
  auto replay_once = [&](const std::string& input, std::set<std::string>& regenerated) {
    rt::ReplayOptions ro;
    ro.input_log = input;
    ro.output_log = o.output_log;
    ro.prefix = o.prefix;
    ro.tail = static_cast<rt::Micros>(o.tail_s * 1e6);
    rt::ReplayRunner runner(ro);
    for (auto& b : built)
      for (auto& n : b->nodes) runner.add(*n);
    const auto result = runner.run();
    regenerated.clear();
    for (const auto& c : runner.advertised()) regenerated.insert(runner.full_channel(c));
    return result;
  };
  rt::ReplayResult result;
  std::set<std::string> regenerated;
  std::string inputs_only;  // --rebase: the input without the regenerated channels
  try {
    result = replay_once(o.input_log, regenerated);
    if (o.rebase) {
      // Replay again over the input without the regenerated channels, so a
      // replay of the rebased log starts at the same first event (timer
      // phases) and sees exactly the same inputs.
      std::vector<rt::LogRecord> filtered;
      for (auto& r : rt::read_log(o.input_log))
        if (!regenerated.count(r.channel)) filtered.push_back(std::move(r));
      inputs_only = o.output_log + ".inputs";
      rt::write_log(inputs_only, filtered);
      built = build();
      result = replay_once(inputs_only, regenerated);
    }
  } catch (const std::exception& e) {
    err << "harvest-replay: " << e.what() << "\n";
    return 3;
  }

  out << "replayed " << o.input_log << " -> " << o.output_log << "\n";
  out << "  events read " << result.events_read << ", delivered " << result.events_delivered
      << ", skipped (regenerated) " << result.events_skipped << ", published " << result.messages_published
      << ", timers fired " << result.timers_fired << "\n";
  for (const auto& b : built)
    for (const auto& n : b->nodes) {
      const auto& st = n->stats();
      out << "  node " << b->spec.label << " (" << b->spec.process
          << (b->spec.config.empty() ? "" : ":" + b->spec.config) << "): received " << st.received << ", published "
          << st.published << ", decode errors " << st.decode_errors << "\n";
    }
  std::string chans;
  for (const auto& c : regenerated) chans += " " + c;
  out << "  regenerated channels:" << chans << "\n";

  int rc = 0;
  try {
    if (o.compare) {
      const auto recorded = rt::read_log(o.input_log);
      const auto replayed = rt::read_log(o.output_log);
      const auto report = compare_logs(recorded, replayed, sorted_channels(regenerated), o.compare_options);
      out << format_report(report, o.compare_options);
      if (!report.ok) rc = 1;
    }
    if (o.rebase) {
      // The inputs merged in time order with the replay output (an input
      // first at equal times: outputs follow the event that caused them).
      const auto input = rt::read_log(inputs_only);
      const auto replayed = rt::read_log(o.output_log);
      std::filesystem::remove(inputs_only);
      std::vector<rt::LogRecord> merged;
      merged.reserve(input.size() + replayed.size());
      std::size_t j = 0;
      for (const auto& r : input) {
        while (j < replayed.size() && replayed[j].timestamp < r.timestamp) merged.push_back(replayed[j++]);
        merged.push_back(r);
      }
      while (j < replayed.size()) merged.push_back(replayed[j++]);
      rt::write_log(o.output_log, merged);
      out << "  rebased: " << o.output_log << " holds the input with the regenerated channels replaced ("
          << merged.size() << " events)\n";
    }
  } catch (const std::exception& e) {
    err << "harvest-replay: " << e.what() << "\n";
    return 3;
  }
  return rc;
}

int replay_main(int argc, char** argv) {
  CLI::App app{"Replay chosen nodes over an LCM log and compare with the recording (docs/replay.md)"};
  ReplayToolOptions o;
  std::vector<std::string> tolerances, ignores;
  bool list = false;
  app.add_option("log", o.input_log, "input LCM log");
  app.add_option("--node", o.nodes, "[LABEL=]PROCESS[:CONFIG] (repeatable, see --list-nodes)")->allow_extra_args(false);
  app.add_option("--set", o.overrides, "[LABEL:]key=value configuration override (repeatable)")
      ->allow_extra_args(false);
  app.add_option("--out", o.output_log, "output log of the regenerated messages");
  app.add_option("--prefix", o.prefix, "channel prefix of the recorded graph");
  app.add_flag("--compare", o.compare, "compare regenerated channels with the recorded ones; exit 1 on differences");
  app.add_option("--tolerance", tolerances, "CHANNEL.field=abs (indices as [], '*' for any channel)")
      ->allow_extra_args(false);
  app.add_option("--ignore", ignores, "CHANNEL.field not compared (e.g. '*.header.seq')")->allow_extra_args(false);
  app.add_flag("--allow-unmatched", o.compare_options.allow_unmatched,
               "messages only recorded or only replayed (e.g. dropped live) are listed but do not fail");
  app.add_option("--max-messages", o.compare_options.max_messages_per_channel, "differing messages shown per channel")
      ->capture_default_str();
  app.add_option("--tail", o.tail_s, "keep firing timers this long after the last event [s]");
  app.add_flag("--rebase", o.rebase,
               "write OUT as the input with the regenerated channels replaced (refresh a reference log)");
  app.add_flag("--list-nodes", list, "print the replayable nodes and exit");
  try {
    app.parse(argc, argv);
    if (!list) {
      if (o.input_log.empty()) throw CLI::RequiredError("log");
      if (o.output_log.empty()) throw CLI::RequiredError("--out");
    }
    for (const auto& t : tolerances) o.compare_options.add_tolerance(t);
    for (const auto& i : ignores) o.compare_options.add_ignore(i);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "harvest-replay: " << e.what() << "\n";
    return 2;
  }
  if (list) {
    for (const auto& n : node_registry()) std::cout << n.process << "\t" << n.summary << "\n";
    return 0;
  }
  return run_replay_tool(o, std::cout, std::cerr);
}

}  // namespace harvest::logtools
