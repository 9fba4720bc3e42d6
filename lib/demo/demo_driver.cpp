#include "demo/demo_driver.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <optional>

#include "config/config.hpp"
#include "demo/progress.hpp"
#include "demo/run_ports.hpp"
#include "demo/set_rewrite.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "launch/child.hpp"
#include "runtime/channels.hpp"
#include "runtime/checked_subscription.hpp"
#include "runtime/clock.hpp"
#include "runtime/file_stamp.hpp"
#include "runtime/log_io.hpp"
#include "security/authority.hpp"
#include "servo/operator_command.hpp"
#include "sim/evaluation.hpp"
#include "sim/scenario.hpp"
#include "sim/sim_node.hpp"

#ifndef HARVEST_SOURCE_DIR
#define HARVEST_SOURCE_DIR "."
#endif

namespace harvest::demo {

namespace fs = std::filesystem;
namespace ch = harvest::channels;

namespace {

std::atomic<int> g_signal{0};
// Not extern "C": a C-linkage name ignores the anonymous namespace and clashed with the runtime's on_signal.
void on_demo_signal(int sig) { g_signal = sig; }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Receives what the demo watches; one message at a time, on this thread.
class Monitor {
 public:
  explicit Monitor(Progress& p) : progress_(p) {}
  void status(const harvest_status_t& m) { pending_ = m; }
  void truth(const sim_truth_t& m) { progress_.on_truth(m); }
  std::optional<harvest_status_t> take() {
    auto s = std::move(pending_);
    pending_.reset();
    return s;
  }

 private:
  Progress& progress_;
  std::optional<harvest_status_t> pending_;
};

struct RunResult {
  int launcher_exit = -1;
  bool started = false;
  std::string problem;  // why the run did not end normally
  fs::path log;         // the first part of the recording
  std::vector<fs::path> parts;
};

// The recording the launcher made for this run (file_prefix runK): its parts
// in order (runK-TIME.lcm.00, .01, ...; several when split by size).
std::vector<fs::path> find_log(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> parts;
  if (!fs::exists(dir)) return parts;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix + "-", 0) == 0 && name.find(".lcm") != std::string::npos) parts.push_back(e.path());
  }
  std::sort(parts.begin(), parts.end());
  return parts;
}

RunResult run_once(const DemoOptions& o, const sim::Scenario& scenario, int run, lcm::LCM& lcm, std::ostream& out,
                   std::ostream& err) {
  RunResult r;
  const std::string prefix = "run" + std::to_string(run);
  const fs::path set_copy = o.out_dir / (prefix + "-set.yaml");
  {
    SetRewrite rw;
    rw.set_file = o.set_file;
    rw.bin_dir = o.bin_dir;
    for (const auto& [name, assignment] : o.process_sets) {
      rw.extra_args[name].push_back("--set");
      rw.extra_args[name].push_back(assignment);
    }
    std::vector<std::string> sim_sets{"scenario=" + o.scenario.string(), "run=" + std::to_string(run)};
    if (!o.seeds.empty()) sim_sets.push_back("seed=" + std::to_string(o.seeds[static_cast<std::size_t>(run)]));
    for (const std::string& a : sim_sets) {
      rw.extra_args["sim"].push_back("--set");
      rw.extra_args["sim"].push_back(a);
    }
    std::ofstream f(set_copy);
    f << "# Written by harvest-demo from " << o.set_file.string() << " for " << prefix << "\n" << rewrite_set(rw);
  }
  // This run's own virtual CAN bus and board port: the set's ${can_bus} and
  // ${board_port} (config/site/sim.yaml holds the defaults for a set started by hand).
  const RunPorts ports = pick_run_ports();
  out << "run " << run << ": virtual CAN bus " << ports.can_bus << ", board port " << ports.board_port << std::endl;
  const std::vector<std::string> argv = {(o.bin_dir / "harvest-launch").string(),
                                         set_copy.string(),
                                         "--exit-with",
                                         "sim",
                                         "--no-table",
                                         "--lcm-url",
                                         o.lcm_url,
                                         "--instance",
                                         "demo-launch",
                                         "--set",
                                         "recording.enabled=true",
                                         "--set",
                                         "recording.folder=" + o.out_dir.string(),
                                         "--set",
                                         "recording.file_prefix=" + prefix,
                                         "--set",
                                         "recording.split_mb=" + std::to_string(o.split_mb),
                                         "--set",
                                         "recording.image_rate_hz=" + std::to_string(o.image_rate_hz),
                                         "--set",
                                         "site.can_bus=" + ports.can_bus,
                                         "--set",
                                         "site.board_port=" + std::to_string(ports.board_port)};
  std::ofstream launch_log(o.out_dir / (prefix + "-launch.log"));
  const launch::Spawned child = launch::spawn(argv, {}, o.root);
  launch::LineBuffer lines;
  auto on_line = [&](const std::string& line) {
    launch_log << line << std::endl;  // readable while the run goes on
    // The launcher's own lines (starts, exits, restarts) and every error reach the terminal.
    // So do the recorder's size/rate reports and disk warnings.
    if (line.rfind("[launch]", 0) == 0 || line.rfind("[recorder]", 0) == 0 ||
        line.find(" error ") != std::string::npos || line.find("critical") != std::string::npos)
      out << "  " << line << std::endl;
  };

  Progress progress(run);
  Monitor monitor(progress);
  std::optional<rt::CheckedSubscription<harvest_status_t>> s1;
  std::optional<rt::CheckedSubscription<sim_truth_t>> s2;
  s1.emplace(lcm, ch::kHarvestStatus, [&](const harvest_status_t& m) { monitor.status(m); });
  s2.emplace(lcm, sim::kSimTruthChannel, [&](const sim_truth_t& m) { monitor.truth(m); });

  const auto t0 = std::chrono::steady_clock::now();
  const double deadline_s = scenario.time_limit_s + o.run_margin_s;
  double last_start_sent = -10.0, stop_sent_at = -1.0, final_since = -1.0;
  // START is signed as an operator with the simulator sets' key (docs/security.md).
  rt::SystemClock signing_clock;
  security::Signer operator_signer(security::sim_key(), "operator", signing_clock);
  bool stopped_by_us = false;  // the run ended because the controller finished
  bool exited = false;
  int status = 0;
  while (!exited) {
    pollfd fds[2] = {{lcm.getFileno(), POLLIN, 0}, {child.output_fd, POLLIN, 0}};
    ::poll(fds, child.output_fd >= 0 ? 2 : 1, 100);
    if (fds[0].revents & POLLIN) lcm.handle();
    if (child.output_fd >= 0 && (fds[1].revents & (POLLIN | POLLHUP))) {
      char buf[4096];
      ssize_t n;
      while ((n = ::read(child.output_fd, buf, sizeof buf)) > 0) lines.feed(buf, static_cast<std::size_t>(n), on_line);
    }
    const double t = seconds_since(t0);
    if (auto st = monitor.take())
      if (auto line = progress.on_status(*st, t)) out << *line << std::endl;

    // START until the controller obeys (it refuses while it has no robot state yet).
    if (!progress.started() && progress.controller_seen() && t - last_start_sent >= 1.0 && stop_sent_at < 0) {
      auto msg =
          std::get<operator_command_t>(servo::make_operator_message("start", "harvest-demo", "", rt::wall_time_now()));
      operator_signer.sign(msg);
      lcm.publish(ch::kOperatorCommand, &msg);
      last_start_sent = t;
    }
    // A controller that is DONE or in FAULT ends the run (the simulator would
    // otherwise wait for its time limit); give the last events time to arrive.
    const bool final_state = progress.state() == "DONE" || progress.state() == "FAULT";
    if (!final_state)
      final_since = -1.0;
    else if (final_since < 0)
      final_since = t;
    if (final_since >= 0 && t - final_since > 5.0 && stop_sent_at < 0) {
      if (progress.state() == "FAULT") r.problem = "the controller is in FAULT (see " + prefix + "-launch.log)";
      out << "run " << run << ": controller " << progress.state() << ", stopping the set" << std::endl;
      launch::signal_group(child.pid, SIGINT);
      stop_sent_at = t;
      stopped_by_us = true;
    }
    std::string why;
    if (g_signal)
      why = "interrupted";
    else if (!progress.started() && t > o.start_timeout_s)
      why = "the controller did not start within " + std::to_string(static_cast<int>(o.start_timeout_s)) + " s";
    else if (t > deadline_s)
      why = "the run went past the scenario's time limit";
    if (!why.empty() && stop_sent_at < 0) {
      r.problem = why;
      err << "harvest-demo: run " << run << ": " << why << "; stopping the set\n";
      launch::signal_group(child.pid, SIGINT);
      stop_sent_at = t;
    }
    if (stop_sent_at >= 0 && t - stop_sent_at > 20.0) launch::signal_group(child.pid, SIGKILL);
    exited = ::waitpid(child.pid, &status, WNOHANG) == child.pid;
  }
  char buf[4096];
  ssize_t n;
  while (child.output_fd >= 0 && (n = ::read(child.output_fd, buf, sizeof buf)) > 0)
    lines.feed(buf, static_cast<std::size_t>(n), on_line);
  lines.flush(on_line);
  if (child.output_fd >= 0) ::close(child.output_fd);
  s1.reset();
  s2.reset();
  r.launcher_exit = launch::exit_code_of(status);
  r.started = progress.started();
  if (r.problem.empty() && r.launcher_exit != 0 && !stopped_by_us)
    r.problem =
        "harvest-launch exited with code " + std::to_string(r.launcher_exit) + " (see " + prefix + "-launch.log)";
  r.parts = find_log(o.out_dir, prefix);
  if (!r.parts.empty())
    r.log = r.parts.front();
  else if (r.problem.empty())
    r.problem = "no recording of the run found in " + o.out_dir.string();
  return r;
}

void write_report(const DemoOptions& o, const sim::Evaluation& e, const std::vector<RunResult>& results,
                  const std::string& table) {
  std::ofstream md(o.out_dir / "report.md");
  md << "# Harvest demo: " << e.scenario << "\n\n"
     << "Scenario file: `" << o.scenario.string() << "`, process set: `" << o.set_file.string() << "`, runs: " << o.runs
     << ".\n\n## Summary\n\n```\n"
     << table << "```\n\n## Runs\n\n| run | log | launcher exit | note |\n|---|---|---|---|\n";
  for (std::size_t i = 0; i < results.size(); ++i)
    md << "| " << i << " | `" << results[i].log.filename().string() << "` | " << results[i].launcher_exit << " | "
       << (results[i].problem.empty() ? "ended normally" : results[i].problem) << " |\n";
  if (fs::exists(o.out_dir / "plots")) {
    md << "\n## Plots\n\n";
    for (const auto& p : fs::directory_iterator(o.out_dir / "plots"))
      if (p.path().extension() == ".png")
        md << "![" << p.path().stem().string() << "](plots/" << p.path().filename().string() << ")\n";
  }
}

}  // namespace

namespace {
std::string seed_text(const std::vector<uint64_t>& seeds) {
  std::string t;
  for (std::size_t i = 0; i < seeds.size(); ++i) t += (i ? "," : "") + std::to_string(seeds[i]);
  return t;
}
}  // namespace

std::vector<uint64_t> parse_seed_list(const std::string& text) {
  std::vector<uint64_t> seeds;
  auto number = [&](const std::string& t) -> uint64_t {
    if (t.empty() || t.find_first_not_of("0123456789") != std::string::npos || t.size() > 18)
      throw std::invalid_argument("'" + t + "' in '" + text + "' is not a seed (a whole number >= 0)");
    return std::stoull(t);
  };
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t dash = item.find('-');
    if (dash == std::string::npos) {
      seeds.push_back(number(item));
    } else {
      const uint64_t from = number(item.substr(0, dash)), to = number(item.substr(dash + 1));
      if (to < from) throw std::invalid_argument("'" + item + "': a range goes up (FROM-TO with FROM <= TO)");
      if (to - from >= 1000) throw std::invalid_argument("'" + item + "': more than 1000 seeds");
      for (uint64_t k = from; k <= to; ++k) seeds.push_back(k);
    }
    start = comma + 1;
  }
  if (seeds.size() > 1000) throw std::invalid_argument("'" + text + "': more than 1000 seeds");
  return seeds;
}

bool parse_demo_args(int argc, char** argv, DemoOptions& o, int& exit_code) {
  CLI::App app{"Run the simulated harvest end to end: simulator + the field process set (docs/demo.md)"};
  o.root = fs::path(HARVEST_SOURCE_DIR);
  std::string scenario = "config/scenarios/experiment1.yaml", set = "config/sets/sim.yaml", out, summary, bin;
  app.add_option("--scenario", scenario, "scenario file (config/scenarios/*.yaml)")->capture_default_str();
  auto* runs_opt = app.add_option("--runs", o.runs, "repeat the scenario this many times from its start")
                       ->check(CLI::Range(1, 1000));
  std::string seeds;
  app.add_option("--seeds", seeds,
                 "a tree benchmark: one run per seed, the scenario drawn with that seed (\"1-10\", \"3,7,11-12\"); "
                 "the summary gives each run's figures and the mean, worst and spread")
      ->excludes(runs_opt)
      ->check([](const std::string& v) {
        try {
          parse_seed_list(v);
          return std::string();
        } catch (const std::exception& e) {
          return std::string(e.what());
        }
      });
  app.add_option("--summary", summary, "also write the machine-readable summary (JSON) here");
  app.add_option("--set", set, "process set to run")->capture_default_str();
  app.add_option("--out", out, "output folder (default logs/demo/<UTC time>-<scenario>)");
  app.add_option("--lcm-url", o.lcm_url, "LCM URL (default: a private port on this host, TTL 0)");
  app.add_option("--bin-dir", bin, "where the harvest-* executables are (default: beside harvest-demo)");
  app.add_option("--scenario-set", o.scenario_sets,
                 "KEY=VALUE, an override of the scenario (e.g. look.style=field); the scenario run is written to "
                 "<out>/scenario.yaml");
  std::vector<std::string> process_sets;
  app.add_option("--process-set", process_sets, "NAME:KEY=VALUE, a configuration override for one process of the set")
      ->check([](const std::string& v) {
        const auto colon = v.find(':');
        return colon == std::string::npos || colon == 0 || v.find('=', colon) == std::string::npos
                   ? std::string("expected NAME:KEY=VALUE")
                   : std::string();
      });
  app.add_option("--split-mb", o.split_mb, "recording: start a new part every N MB (0: one file)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--image-rate", o.image_rate_hz,
                 "recording: camera frames (CAMERA_.*) at most this many per second (0: every frame); the "
                 "processes still see every frame")
      ->check(CLI::NonNegativeNumber);
  bool no_plots = false;
  app.add_flag("--no-plots", no_plots, "skip the plots");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    exit_code = app.exit(e);
    return false;
  }
  o.plots = !no_plots;
  if (!seeds.empty()) {
    o.seeds = parse_seed_list(seeds);
    o.runs = static_cast<int>(o.seeds.size());
  }
  for (const auto& v : process_sets) o.process_sets.emplace_back(v.substr(0, v.find(':')), v.substr(v.find(':') + 1));
  // Relative paths: from the current folder if they exist there, else from the repository root.
  auto from_root = [&](const std::string& p) {
    if (fs::path(p).is_absolute()) return fs::path(p);
    return fs::exists(p) ? fs::absolute(p) : o.root / p;
  };
  o.scenario = from_root(scenario);
  o.set_file = from_root(set);
  if (!out.empty()) o.out_dir = from_root(out);
  if (!summary.empty()) o.summary_path = from_root(summary);
  o.bin_dir = bin.empty() ? fs::canonical("/proc/self/exe").parent_path() : from_root(bin);
  return true;
}

int run_demo(const DemoOptions& opt, std::ostream& out, std::ostream& err) {
  DemoOptions o = opt;
  if (!o.seeds.empty()) o.runs = static_cast<int>(o.seeds.size());
  sim::Scenario scenario;
  try {
    scenario = sim::load_scenario(o.scenario.string());
  } catch (const std::exception& e) {
    err << "harvest-demo: " << e.what() << '\n';
    return 2;
  }
  if (!fs::exists(o.set_file)) {
    err << "harvest-demo: " << o.set_file.string() << ": process set not found\n";
    return 2;
  }
  if (o.out_dir.empty()) o.out_dir = o.root / "logs" / "demo" / (rt::utc_file_stamp() + "-" + scenario.name);
  fs::create_directories(o.out_dir);
  if (!o.scenario_sets.empty()) {  // the overridden scenario, a file the simulator reads and harvest-evaluate can
    try {
      auto doc = config::Document::load_file(o.scenario);
      for (const auto& a : o.scenario_sets) doc.apply_override(a);
      const fs::path copy = o.out_dir / "scenario.yaml";
      std::ofstream(copy) << "# Written by harvest-demo: " << o.scenario.string() << " with --scenario-set\n"
                          << doc.emit();
      o.scenario = copy;
      scenario = sim::load_scenario(o.scenario.string());
    } catch (const std::exception& e) {
      err << "harvest-demo: --scenario-set: " << e.what() << '\n';
      return 2;
    }
  }
  if (o.lcm_url.empty()) o.lcm_url = pick_run_ports().lcm_url;
  lcm::LCM lcm(o.lcm_url);
  if (!lcm.good()) {
    err << "harvest-demo: cannot open LCM at " << o.lcm_url << " (try `tools/harvest netfix`)\n";
    return 1;
  }
  std::signal(SIGINT, on_demo_signal);
  std::signal(SIGTERM, on_demo_signal);

  out << "harvest-demo: scenario '" << scenario.name << "' (" << o.scenario.string() << "), " << o.runs << " run(s)"
      << (o.seeds.empty() ? "" : " (seeds " + seed_text(o.seeds) + ")") << ", set " << o.set_file.filename().string()
      << ", output in " << o.out_dir.string() << std::endl;
  sim::Evaluation e;
  std::vector<RunResult> results;
  int code = 0;
  for (int run = 0; run < o.runs && !g_signal; ++run) {
    RunResult r;
    try {
      r = run_once(o, scenario, run, lcm, out, err);
    } catch (const std::exception& ex) {  // the set cannot be written or started
      err << "harvest-demo: " << ex.what() << '\n';
      return 2;
    }
    if (!r.problem.empty()) code = 1;
    if (!r.log.empty()) {
      try {
        std::vector<rt::LogRecord> records;
        for (const auto& part : r.parts) {
          auto more = rt::read_log(part.string());
          records.insert(records.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
        }
        const auto run_scenario = o.seeds.empty()
                                      ? scenario.for_run(run)
                                      : scenario.for_run(run).with_seed(o.seeds[static_cast<std::size_t>(run)]);
        sim::evaluate_run(records, run_scenario, run, e);
      } catch (const std::exception& ex) {
        r.problem += (r.problem.empty() ? "" : "; ") + std::string("evaluation failed: ") + ex.what();
        code = 1;
      }
    }
    out << "run " << run << ": " << (r.problem.empty() ? "ended normally" : r.problem) << std::endl;
    results.push_back(r);
  }
  sim::finish(e);
  const std::string table = sim::to_table(e);
  out << '\n' << table;
  const std::string json = sim::to_json(e);
  std::ofstream(o.out_dir / "summary.json") << json;
  if (!o.summary_path.empty()) {
    if (o.summary_path.has_parent_path()) fs::create_directories(o.summary_path.parent_path());
    std::ofstream s(o.summary_path);
    s << json;
    if (!s) err << "harvest-demo: cannot write " << o.summary_path.string() << '\n';
  }
  const fs::path plot_tool = o.root / "tools" / "plot_log.py";
  if (o.plots && fs::exists(plot_tool) && !results.empty() && !results.back().log.empty()) {
    const std::string cmd = "/usr/bin/python3 '" + plot_tool.string() + "' '" + results.back().log.string() +
                            "' --out '" + (o.out_dir / "plots").string() + "' --harvest-log '" +
                            (o.bin_dir / "harvest-log").string() + "' >> '" + (o.out_dir / "plots.log").string() +
                            "' 2>&1";
    if (std::system(cmd.c_str()) != 0)
      err << "harvest-demo: plotting failed, see " << (o.out_dir / "plots.log") << '\n';
  }
  write_report(o, e, results, table);
  out << "\nlogs, summary.json and report.md in " << o.out_dir.string() << std::endl;
  return g_signal ? 130 : code;
}

}  // namespace harvest::demo
