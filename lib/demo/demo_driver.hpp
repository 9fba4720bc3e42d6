// harvest-demo: runs the simulated harvest end to end. For each run it starts
// the process set through harvest-launch (the simulator told which scenario
// and run), records it, starts the harvest with an operator START, prints
// progress from HARVEST_STATUS, and when the simulator ends the run scores the
// log against the simulator's ground truth. Finally it prints the summary
// table and leaves logs, summary.json and report.md (plus plots when
// tools/plot_log.py is present) in the output folder. docs/demo.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace harvest::demo {

struct DemoOptions {
  std::filesystem::path root;      // repository root (processes run here)
  std::filesystem::path bin_dir;   // harvest-* executables
  std::filesystem::path set_file;  // process set, default config/sets/sim.yaml
  std::filesystem::path scenario;  // scenario file
  int runs = 1;
  // --seeds: one run per seed, the scenario drawn with that seed (another tree of the same kind); empty: the
  // scenario's own seed for every run.
  std::vector<uint64_t> seeds;
  std::filesystem::path out_dir;       // default logs/demo/<UTC time>-<scenario>
  std::filesystem::path summary_path;  // extra copy of summary.json (--summary)
  std::string lcm_url;                 // default: a multicast port free on this host, TTL 0
  bool plots = true;
  double split_mb = 0;       // recording: a new part every N MB (0: one file)
  double image_rate_hz = 0;  // recording: camera frames at most this often (0: every frame)
  // --process-set NAME:KEY=VALUE: `--set KEY=VALUE` appended to process NAME.
  std::vector<std::pair<std::string, std::string>> process_sets;
  // --scenario-set KEY=VALUE: the scenario with these overrides (e.g. look.style=field), written to
  // <out>/scenario.yaml, which the simulator runs and the runs are scored against.
  std::vector<std::string> scenario_sets;
  double start_timeout_s = 30.0;  // processes up and START obeyed within this
  double run_margin_s = 60.0;     // beyond the scenario's time limit before a run is abandoned
};

// Runs the demo; returns the process exit code (0 when every run ended
// normally, 1 otherwise, 2 on bad options). Progress goes to `out`.
int run_demo(const DemoOptions& options, std::ostream& out, std::ostream& err);

// "1-10", "3,7,11-12" -> the seeds in that order. Throws std::invalid_argument saying what is wrong.
std::vector<uint64_t> parse_seed_list(const std::string& text);

// Command line -> options (CLI11); returns false and the exit code for --help
// or errors.
bool parse_demo_args(int argc, char** argv, DemoOptions& options, int& exit_code);

}  // namespace harvest::demo
