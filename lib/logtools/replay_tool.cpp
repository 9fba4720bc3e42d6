#include "logtools/replay_tool.hpp"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <harvest/config_snapshot_t.hpp>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "config/config.hpp"
#include "features/nodes.hpp"
#include "logtools/explain.hpp"
#include "runtime/allocator.hpp"
#include "runtime/channels.hpp"
#include "runtime/journal_runner.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "servo/nodes.hpp"
#include "vision/detector_node.hpp"
#include "vision/reconstructor_node.hpp"

namespace harvest::logtools {

const std::vector<ReplayableNode>& node_registry() {
  static const std::vector<ReplayableNode> r = {
      {"fruit-detector", vision::make_fruit_detector, "CAMERA_* -> FRUIT_* (camera: fixed|hand in its config)"},
      {"reconstructor", vision::make_reconstructor, "FRUIT_FIXED, FRUIT_HAND, ROBOT_STATE, HARVEST_STATUS -> TARGETS"},
      {"servo-controller", servo::make_servo_controller,
       "TARGETS, FRUIT_HAND, ROBOT_STATE, IR_RANGE, GRIPPER_STATE, OPERATOR_COMMAND -> ROBOT_COMMAND, GRIPPER_COMMAND, "
       "HARVEST_STATUS"},
      {"feature-tracker", features::make_feature_tracker, "CAMERA_HAND -> FEATURES_HAND"},
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

std::vector<LoggedConfig> logged_configs(const std::string& log, const std::string& prefix) {
  std::vector<LoggedConfig> out;
  std::set<std::string> seen;
  const std::string channel = prefix + channels::kConfig;
  for (const auto& r : rt::read_log(log)) {
    if (r.channel != channel) continue;
    const auto decoded = rt::decode<config_snapshot_t>(r.data);
    if (!decoded) continue;
    const config_snapshot_t& m = *decoded;
    // A restarted process publishes again; its first snapshot is the one the
    // recording started with.
    if (!seen.insert(m.instance).second) continue;
    out.push_back({m.process, m.instance, m.config_path, m.yaml, m.command_line, r.timestamp, m.header.utime});
  }
  return out;
}

std::vector<NodeSpec> nodes_from_configs(const std::vector<LoggedConfig>& configs) {
  std::vector<NodeSpec> out;
  const auto& reg = node_registry();
  for (const auto& c : configs) {
    if (std::none_of(reg.begin(), reg.end(), [&](const ReplayableNode& n) { return n.process == c.process; })) continue;
    NodeSpec s;
    s.label = c.instance.empty() ? c.process : c.instance;
    s.process = c.process;
    // Relative paths inside the configuration (calibration files) resolve
    // beside the file it was loaded from, as they did live.
    s.config = c.config_path.empty() ? "<CONFIG of " + s.label + ">" : c.config_path;
    s.yaml = c.yaml.empty() ? "{}" : c.yaml;
    s.start = c.start();
    out.push_back(std::move(s));
  }
  return out;
}

namespace {
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

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
  std::string input_log = o.input_log;        // the log's own nodes: from the moment all of them ran
  std::optional<rt::Micros> own_nodes_start;  // the log's own nodes: when the replay starts
  CompareOptions compare_options = o.compare_options;
  try {
    std::vector<NodeSpec> specs;
    std::map<std::string, int> per_process;
    if (o.nodes.empty()) {
      // No --node: the nodes and configurations the log was recorded with.
      const auto configs = logged_configs(o.input_log, o.prefix);
      specs = nodes_from_configs(configs);
      std::string used, skipped;
      for (const auto& c : configs) {
        const bool replayed =
            std::any_of(specs.begin(), specs.end(), [&](const NodeSpec& s) { return s.label == c.instance; });
        std::string& list = replayed ? used : skipped;
        list += (list.empty() ? "" : ", ") + c.instance + " (" + c.process + ")";
      }
      if (specs.empty())
        throw std::invalid_argument(o.input_log + ": no CONFIG snapshot of a replayable process (" +
                                    (configs.empty() ? std::string("no CONFIG at all") : "only " + skipped) +
                                    "): give the nodes with --node (see --list-nodes)");
      out << "nodes from the log's CONFIG snapshots: " << used << "\n";
      if (!skipped.empty()) out << "  not replayable (devices, tools): " << skipped << "\n";
      // Live, each process saw only what was published after it started (its
      // CONFIG); the recording began earlier. Each node is attached at its own
      // process's start, so it sees what its live twin saw and runs its timers
      // from the same moment; the replay begins with the first of them.
      rt::Micros start = std::numeric_limits<rt::Micros>::max();
      for (const auto& s : specs) start = std::min<rt::Micros>(start, s.start);
      input_log = o.output_log + ".input";
      const std::size_t before = rt::copy_log_from(o.input_log, input_log, start);
      own_nodes_start = start;
      out << "  each node from its process's start (CONFIG snapshot, log time):";
      for (const auto& s : specs) out << " " << s.label << " " << s.start;
      out << "; " << before << " earlier events left out\n";
      // header.seq counts a process's messages since it started, before that moment too.
      compare_options.add_ignore("*.header.seq");
      compare_options.add_ignore("*.header.source_seq");
      compare_options.add_ignore("*.auth");
      out << "  header.seq and header.source_seq not compared (each process counts its messages from its own start, "
             "before the replay's), nor a command's auth block (its signature, stamped when sent, like "
             "header.publish_utime)\n";
      out << "  each node replayed against the recording: it receives what its live twin received, when it did "
             "(recorded detections, targets and statuses included)\n";
    }
    for (const auto& n : o.nodes) specs.push_back(parse_node_spec(n));
    for (const auto& s : specs) ++per_process[s.process];
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
        config::Document doc =
            s.yaml.empty() ? rt::load_config(s.config, {}) : config::Document::load_string(s.yaml, s.config);
        for (const auto& a : ov) doc.apply_override(a);
        auto b = std::make_unique<BuiltNode>(BuiltNode{s, std::move(doc), {}});
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
  struct {
    double wall_s = 0, cpu_s = 0;
  } speed;
  // The log's own nodes with a journal of their process are replayed from it, each on its own.
  std::map<std::string, rt::Journal> journals;
  if (own_nodes_start && o.use_journals) {
    try {
      journals = rt::read_journals(o.input_log, o.prefix);
    } catch (const std::exception& e) {
      err << "harvest-replay: " << e.what() << "\n";
      return 3;
    }
  }
  auto journal_of = [&](const BuiltNode& b) -> const rt::Journal* {
    auto it = journals.find(b.spec.label);
    return it == journals.end() || it->second.entries.empty() ? nullptr : &it->second;
  };
  std::vector<std::string> journal_lines;
  auto replay_once = [&](const std::string& input, std::set<std::string>& regenerated) {
    journal_lines.clear();
    regenerated.clear();
    const auto wall0 = std::chrono::steady_clock::now();
    const std::clock_t cpu0 = std::clock();
    // Every journalled process in one pass over the log.
    std::vector<std::unique_ptr<rt::JournalRunner>> journalled;
    std::vector<rt::JournalRunner*> runners;
    std::vector<const BuiltNode*> journalled_nodes;
    for (auto& b : built) {
      const rt::Journal* j = journal_of(*b);
      if (j == nullptr) continue;
      journalled.push_back(std::make_unique<rt::JournalRunner>(o.prefix, b->spec.start, *j));
      for (auto& n : b->nodes) journalled.back()->add(*n);
      runners.push_back(journalled.back().get());
      journalled_nodes.push_back(b.get());
    }
    if (!runners.empty()) rt::replay_journals(input, runners);
    for (std::size_t i = 0; i < runners.size(); ++i) {
      const rt::JournalRunner& jr = *runners[i];
      const BuiltNode& b = *journalled_nodes[i];
      const rt::Journal& j = *journal_of(b);
      const auto& r = jr.result();
      for (const auto& c : jr.advertised()) regenerated.insert(jr.full_channel(c));
      std::string line =
          "  " + b.spec.label + " replayed from its journal (" + std::to_string(j.records) + " records" +
          (j.recovered_records > 0 ? ", " + std::to_string(j.recovered_records) + " lost by the logger and recovered"
                                   : std::string()) +
          (j.missing_records > 0 ? ", " + std::to_string(j.missing_records) + " lost by the logger" : std::string()) +
          "): " + std::to_string(r.messages) + " inputs at their live times, " + std::to_string(r.timers) +
          " timer firings as they ran, " + std::to_string(r.missing_inputs) + " inputs not in the recording";
      for (const auto& m : r.missing) line += "\n    missing: " + m;
      journal_lines.push_back(line);
    }
    rt::ReplayOptions ro;
    ro.input_log = input;
    ro.output_log = o.output_log;
    ro.prefix = o.prefix;
    ro.tail = static_cast<rt::Micros>(o.tail_s * 1e6);
    ro.isolated = own_nodes_start.has_value();  // each node against what its live twin received
    rt::ReplayRunner runner(ro);
    for (auto& b : built)
      for (auto& n : b->nodes) {
        if (journal_of(*b) != nullptr) continue;
        if (ro.isolated && b->spec.start > 0)
          runner.add_from(*n, b->spec.start);
        else
          runner.add(*n);
      }
    const auto result = runner.run();
    for (const auto& c : runner.advertised()) regenerated.insert(runner.full_channel(c));
    if (!runners.empty() && !o.output_log.empty()) {
      // One output log, in time order (stable: the plain replay's first, then each process's, each in its order).
      std::vector<rt::LogRecord> merged = rt::read_log(o.output_log);
      for (const auto& jr : journalled) merged.insert(merged.end(), jr->published().begin(), jr->published().end());
      std::stable_sort(merged.begin(), merged.end(),
                       [](const rt::LogRecord& a, const rt::LogRecord& b) { return a.timestamp < b.timestamp; });
      rt::write_log(o.output_log, merged);
    }
    // The tool's own speed (not the nodes' clock, which is the log's): wall and CPU time of the runs.
    speed.cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
    speed.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return result;
  };
  rt::ReplayResult result;
  std::set<std::string> regenerated;
  std::string inputs_only;  // --rebase: the input without the regenerated channels
  try {
    result = replay_once(input_log, regenerated);
    if (o.rebase) {
      // Replay again over the input without the regenerated channels, so a
      // replay of the rebased log starts at the same first event (timer
      // phases) and sees exactly the same inputs.
      std::vector<rt::LogRecord> filtered;
      for (auto& r : rt::read_log(input_log))
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
  const double span_s = static_cast<double>(result.last_time - result.first_time) * 1e-6;
  out << "  speed: " << fixed(span_s, 1) << " s of log replayed in " << fixed(speed.wall_s, 2) << " s ("
      << fixed(speed.cpu_s, 2)
      << " s CPU): " << (speed.wall_s > 0 ? fixed(span_s / speed.wall_s, 0) + "x real time" : std::string("instant"))
      << "\n";
  for (const auto& b : built)
    for (const auto& n : b->nodes) {
      const auto& st = n->stats();
      out << "  node " << b->spec.label << " (" << b->spec.process
          << (b->spec.config.empty() ? "" : ":" + b->spec.config) << "): received " << st.received << ", published "
          << st.published << ", decode errors " << st.decode_errors << "\n";
    }
  for (const auto& l : journal_lines) out << l << "\n";
  std::string chans;
  for (const auto& c : regenerated) chans += " " + c;
  out << "  regenerated channels:" << chans << "\n";

  int rc = 0;
  try {
    if (o.compare) {
      const auto recorded = rt::read_log(input_log);
      const auto replayed = rt::read_log(o.output_log);
      auto report = compare_logs(recorded, replayed, sorted_channels(regenerated), compare_options);
      if (own_nodes_start) {
        // What the logs can tell about each message without a partner.
        explain_unmatched(report, rt::read_log(o.input_log), regenerated, *own_nodes_start);
        report.explained =
            !report.ok && std::all_of(report.channels.begin(), report.channels.end(),
                                      [&](const ChannelReport& c) { return c.ok(compare_options) || c.explained(); });
      }
      out << format_report(report, compare_options);
      if (!report.ok && !report.explained) rc = 1;
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
  if (input_log != o.input_log) std::filesystem::remove(input_log);
  return rc;
}

int replay_main(int argc, char** argv) {
  CLI::App app{"Replay chosen nodes over an LCM log and compare with the recording (docs/replay.md)"};
  ReplayToolOptions o;
  std::vector<std::string> tolerances, ignores;
  bool list = false;
  std::string temporary_out;  // no --out with the log's own nodes: a file removed afterwards
  app.add_option("log", o.input_log, "input LCM log");
  app.add_option("--node", o.nodes,
                 "[LABEL=]PROCESS[:CONFIG] (repeatable, see --list-nodes); none: the nodes and configurations of "
                 "the log's CONFIG snapshots, compared")
      ->allow_extra_args(false);
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
  bool ignore_journals = false;
  app.add_flag("--ignore-journals", ignore_journals,
               "replay the log's own nodes by the log's order and their timers' due times even where their process "
               "published a JOURNAL (approximate; docs/replay.md)");
  app.add_flag("--list-nodes", list, "print the replayable nodes and exit");
  try {
    app.parse(argc, argv);
    if (!list) {
      if (o.input_log.empty()) throw CLI::RequiredError("log");
      if (o.nodes.empty()) o.compare = true;  // the log's own nodes: the point is the comparison
      if (o.output_log.empty()) {
        if (!o.nodes.empty() || o.rebase) throw CLI::RequiredError("--out");
        temporary_out =
            (std::filesystem::temp_directory_path() / ("harvest-replay-" + std::to_string(::getpid()) + ".lcmlog"))
                .string();
        o.output_log = temporary_out;
      }
    }
    for (const auto& t : tolerances) o.compare_options.add_tolerance(t);
    for (const auto& i : ignores) o.compare_options.add_ignore(i);
    o.use_journals = !ignore_journals;
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
  if (!rt::keep_freed_memory()) std::cerr << "harvest-replay: the allocator refused its settings (a slower replay)\n";
  const int rc = run_replay_tool(o, std::cout, std::cerr);
  if (!temporary_out.empty()) std::filesystem::remove(temporary_out);
  return rc;
}

}  // namespace harvest::logtools
