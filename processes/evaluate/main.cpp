// harvest-evaluate: scores simulated runs from their logs against the
// simulator's ground truth (docs/simulator.md#evaluation).
//
//   harvest-evaluate --scenario config/scenarios/experiment1.yaml [--summary out.json] LOG...
#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "runtime/log_io.hpp"
#include "sim/evaluation.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Score simulated harvest runs from their LCM logs (one log per run)"};
  std::string scenario_path, summary_path;
  std::vector<std::string> logs;
  app.add_option("--scenario", scenario_path, "scenario file the runs used")->required()->check(CLI::ExistingFile);
  app.add_option("--summary", summary_path, "write the machine-readable summary (JSON) here");
  app.add_option("logs", logs, "LCM logs, one per run, in run order")->required()->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  try {
    const harvest::sim::Scenario scenario = harvest::sim::load_scenario(scenario_path);
    harvest::sim::Evaluation e;
    for (std::size_t i = 0; i < logs.size(); ++i) {
      const int run = static_cast<int>(i);
      harvest::sim::evaluate_run(harvest::rt::read_log(logs[i]), scenario.for_run(run), run, e);
    }
    harvest::sim::finish(e);
    std::cout << harvest::sim::to_table(e);
    if (!summary_path.empty()) {
      std::ofstream out(summary_path);
      out << harvest::sim::to_json(e);
      if (!out) throw std::runtime_error("cannot write " + summary_path);
    }
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "harvest-evaluate: %s\n", ex.what());
    return 1;
  }
  return 0;
}
