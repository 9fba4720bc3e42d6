// Scoring simulated runs from their logs against the simulator's ground truth
// (SIM_TRUTH): success rate, cycle times, final gripper-to-fruit error, and
// depth estimation error against distance (the closed-loop analogue of thesis
// table 6-2 / figure 6-7). Used by harvest-evaluate and the demo.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"
#include "sim/scenario.hpp"

namespace harvest::sim {

struct FruitResult {
  int run = 0;
  int sim_id = 0;
  bool counted = false;  // reachable and at least half visible to the fixed camera
  bool reachable = false;
  float visible_fraction = 0.0f;
  std::string outcome;           // picked, knocked off, held, on tree
  int controller_fruit_id = -1;  // the software's global id, when the controller reported it
  std::optional<double> cycle_time_s;
  std::optional<Vec3> final_offset;  // fruit centre minus TCP when the gripper closed [m]
  std::optional<Vec3> final_tool;    // TCP when the gripper closed [m]
  Vec3 true_position = Vec3::Zero();
};

// One run's figures (a seed of a tree benchmark, or a variant).
struct RunFigures {
  int run = 0;
  uint64_t seed = 0;  // the scenario's seed in that run
  int reachable = 0, picked = 0, picked_any = 0;
  double success_rate = 0.0;
  double mean_cycle_s = 0.0, mean_error_mm = 0.0, max_error_mm = 0.0;
  double sim_duration_s = 0.0, time_per_pick_s = 0.0;
};

// Success rate over runs: mean, worst and best run, sample standard deviation.
struct AcrossRuns {
  double mean_success = 0.0, worst_success = 0.0, best_success = 0.0, std_success = 0.0;
  int worst_run = -1;
  double worst_error_mm = 0.0;  // largest final error of any run
};

struct DepthBin {
  double from_m = 0.0, to_m = 0.0;
  int samples = 0;
  double mean_error_m = 0.0, rms_error_m = 0.0;
};

struct Evaluation {
  std::string scenario;
  int runs = 0;
  int fruit_total = 0;
  int reachable = 0;  // counted fruit (reachable, at least half visible)
  int picked = 0;     // counted fruit picked
  int picked_any = 0;
  double success_rate = 0.0;
  double mean_cycle_s = 0.0, max_cycle_s = 0.0;
  double mean_error_mm = 0.0, max_error_mm = 0.0;
  std::array<double, 3> final_tool_std_mm{};  // scatter of the final TCP per axis over picked fruit
  double sim_duration_s = 0.0;
  // Simulated time per fruit picked (any, counted or not): the harvest rate
  // including what the cycle time leaves out (returns home, fruit given up).
  double time_per_pick_s = 0.0;
  std::vector<FruitResult> fruit;
  std::vector<RunFigures> per_run;  // in run order (finish() fills the figures)
  AcrossRuns across_runs;           // finish(), from per_run
  // Time the controller spent in each state (HARVEST_STATUS, log time until
  // the next change; the run's last state until its last status), summed over
  // the runs, in order of first appearance: where a harvest's time goes.
  std::vector<std::pair<std::string, double>> state_time_s;
  std::vector<DepthBin> depth_fixed, depth_hand;
  std::vector<std::string> warnings;
  // (true depth, estimate - truth) [m] per target seen, filled by evaluate_run.
  std::vector<std::pair<double, double>> depth_samples_fixed, depth_samples_hand;
};

// Evaluates one run from its log records. `scenario` provides the true fixed
// camera placement (for depth errors). Throws std::runtime_error if the log has
// no SIM_TRUTH.
void evaluate_run(const std::vector<rt::LogRecord>& log, const Scenario& scenario, int run, Evaluation& into);
// Fills the aggregate figures from the per-fruit results.
void finish(Evaluation& e);

std::string to_json(const Evaluation& e);
// A human-readable summary table (per fruit: outcome, cycle time, error).
std::string to_table(const Evaluation& e);

}  // namespace harvest::sim
