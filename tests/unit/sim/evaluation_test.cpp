#include "sim/evaluation.hpp"

#include <gtest/gtest.h>

#include "harvest/harvest_status_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/json.hpp"
#include "sim/sim_node.hpp"

namespace harvest::sim {
namespace {

constexpr int64_t kT0 = 1'000'000'000;

sim_fruit_truth_t fruit(int id, const Vec3& p, int8_t state, int64_t outcome_utime) {
  sim_fruit_truth_t f{};
  f.sim_id = id;
  f.state = state;
  for (int i = 0; i < 3; ++i) f.position_base[i] = p[i];
  f.diameter_m = 0.07;
  f.visible_fraction_fixed = 1.0f;
  f.reachable = true;
  f.outcome_utime = outcome_utime;
  if (state == sim_fruit_truth_t::PICKED) {
    f.grasp_attempts = 1;
    f.grasp_offset_base[1] = 0.015;
  }
  return f;
}

rt::LogRecord truth(int64_t t, std::vector<sim_fruit_truth_t> fruits) {
  sim_truth_t m{};
  m.header.utime = t;
  m.scenario = "test";
  m.tool_pose.orientation[0] = m.hand_camera_pose.orientation[0] = 1.0;
  m.num_fruits = static_cast<int32_t>(fruits.size());
  m.fruits = std::move(fruits);
  return {t, kSimTruthChannel, rt::encode(m)};
}

// A pick is reported at the release, at the drop pose, and the controller's
// last estimate of the fruit may be far off: the report is matched to the
// fruit the simulator saw detached last before it. The second fruit, picked
// without a controller report, gets the time since the first was decided.
TEST(Evaluation, ControllerCycleTimesAreMatchedByItsFruitEstimate) {
  const Scenario scenario = load_scenario("config/scenarios/experiment1.yaml");
  const Vec3 a(-0.27, 1.02, -0.54), b(-0.07, 1.17, -0.38);
  std::vector<rt::LogRecord> log;
  log.push_back(truth(kT0, {fruit(0, a, sim_fruit_truth_t::ON_TREE, 0), fruit(1, b, sim_fruit_truth_t::ON_TREE, 0)}));
  harvest_status_t s{};
  s.header.utime = kT0 + 9'000'000;
  s.state = "DONE";
  fruit_outcome_t o{};
  o.fruit_id = 7;
  o.outcome = fruit_outcome_t::PICKED;
  o.cycle_time_s = 5.5f;
  const Vec3 estimate(0.6, 2.5, 0.17);  // a bad hand-camera re-estimate, seen in the tree
  const Vec3 drop(-0.5, 0.72, -0.25);
  for (int i = 0; i < 3; ++i) {
    o.target_base[i] = estimate[i];
    o.final_tool_position[i] = drop[i];
  }
  s.outcomes = {o};
  s.num_outcomes = 1;
  log.push_back({s.header.utime, channels::kHarvestStatus, rt::encode(s)});
  log.push_back(truth(kT0 + 10'000'000, {fruit(0, a, sim_fruit_truth_t::PICKED, kT0 + 8'000'000),
                                         fruit(1, b, sim_fruit_truth_t::PICKED, kT0 + 14'000'000)}));
  Evaluation e;
  evaluate_run(log, scenario, 0, e);
  finish(e);
  ASSERT_EQ(e.fruit.size(), 2u);
  EXPECT_EQ(e.fruit[0].controller_fruit_id, 7);
  ASSERT_TRUE(e.fruit[0].cycle_time_s);
  EXPECT_NEAR(*e.fruit[0].cycle_time_s, 5.5, 1e-6);
  ASSERT_TRUE(e.fruit[1].cycle_time_s);
  EXPECT_NEAR(*e.fruit[1].cycle_time_s, 6.0, 1e-6);
  EXPECT_EQ(e.picked, 2);
  EXPECT_EQ(e.reachable, 2);
  EXPECT_NEAR(e.mean_cycle_s, 5.75, 1e-6);
  EXPECT_NEAR(e.mean_error_mm, 15.0, 1e-6);
  // 10 s of truth for 2 fruit picked: 5 s per fruit, in the JSON as well.
  EXPECT_NEAR(e.time_per_pick_s, 5.0, 1e-9);
  const auto j = rt::Json::parse(to_json(e));
  EXPECT_EQ(j["time_per_pick_s"], 5.0) << to_json(e);
  EXPECT_EQ(j["mean_final_error_mm"], 15.0);
  EXPECT_EQ(j["fruit"][1]["cycle_time_s"], 6.0);
}

// A tree benchmark: three runs (seeds 11, 12, 13) scored one by one, then across runs. Run 0 picks both
// counted fruit, run 1 one of two (8 mm and - off), run 2 none of one.
TEST(Evaluation, EachRunsFiguresAndTheirSpreadAcrossRuns) {
  const Scenario base = load_scenario("config/scenarios/experiment1.yaml");
  const Vec3 a(-0.27, 1.02, -0.54), b(-0.07, 1.17, -0.38);
  Evaluation e;
  auto run_log = [&](std::vector<sim_fruit_truth_t> end, int64_t seconds) {
    std::vector<sim_fruit_truth_t> start = end;
    for (auto& f : start) f.state = sim_fruit_truth_t::ON_TREE;
    return std::vector<rt::LogRecord>{truth(kT0, start), truth(kT0 + seconds * 1'000'000, end)};
  };
  evaluate_run(run_log({fruit(0, a, sim_fruit_truth_t::PICKED, kT0 + 5'000'000),
                        fruit(1, b, sim_fruit_truth_t::PICKED, kT0 + 11'000'000)},
                       12),
               base.with_seed(11), 0, e);
  evaluate_run(run_log({fruit(0, a, sim_fruit_truth_t::PICKED, kT0 + 7'000'000),
                        fruit(1, b, sim_fruit_truth_t::ON_TREE, 0)},
                       20),
               base.with_seed(12), 1, e);
  evaluate_run(run_log({fruit(0, a, sim_fruit_truth_t::ON_TREE, 0)}, 30), base.with_seed(13), 2, e);
  finish(e);
  ASSERT_EQ(e.per_run.size(), 3u);
  EXPECT_EQ(e.per_run[1].seed, 12u);
  EXPECT_EQ(e.per_run[0].picked, 2);
  EXPECT_EQ(e.per_run[0].reachable, 2);
  EXPECT_NEAR(e.per_run[0].mean_cycle_s, 5.5, 1e-9);  // 5 s, then 6 s
  EXPECT_NEAR(e.per_run[0].time_per_pick_s, 6.0, 1e-9);
  EXPECT_NEAR(e.per_run[1].success_rate, 0.5, 1e-12);
  EXPECT_NEAR(e.per_run[1].max_error_mm, 15.0, 1e-9);
  EXPECT_EQ(e.per_run[2].picked, 0);
  EXPECT_EQ(e.per_run[2].reachable, 1);
  // Success 1, 0.5, 0: mean 0.5, worst run 2, sample std 0.5.
  EXPECT_NEAR(e.across_runs.mean_success, 0.5, 1e-12);
  EXPECT_NEAR(e.across_runs.worst_success, 0.0, 1e-12);
  EXPECT_EQ(e.across_runs.worst_run, 2);
  EXPECT_NEAR(e.across_runs.best_success, 1.0, 1e-12);
  EXPECT_NEAR(e.across_runs.std_success, 0.5, 1e-12);
  const auto json = rt::Json::parse(to_json(e));
  const auto& run1 = json["per_run"][1];
  EXPECT_EQ(run1["run"], 1);
  EXPECT_EQ(run1["seed"], 12);
  EXPECT_EQ(run1["reachable"], 2);
  EXPECT_EQ(run1["picked"], 1);
  EXPECT_EQ(run1["success_rate"], 0.5);
  EXPECT_EQ(json["across_runs"]["worst_run"], 2);
  EXPECT_EQ(json["across_runs"]["std_success_rate"], 0.5);
  const std::string table = to_table(e);
  EXPECT_NE(table.find("across 3 runs: success mean 50.0 %, worst 0.0 % (run 2)"), std::string::npos) << table;
}

// Where the time goes: each HARVEST_STATUS state counts until the next
// status that changes it (log time), summed over runs; IDLE and DONE are left
// out of the shares.
TEST(Evaluation, TimeInEachControllerStateOverRuns) {
  const Scenario scenario = load_scenario("config/scenarios/experiment1.yaml");
  const Vec3 a(-0.27, 1.02, -0.54);
  const auto status = [](int64_t t, const std::string& state) {
    harvest_status_t s{};
    s.header.utime = t;
    s.state = state;
    return rt::LogRecord{t, channels::kHarvestStatus, rt::encode(s)};
  };
  Evaluation e;
  for (int run = 0; run < 2; ++run) {
    std::vector<rt::LogRecord> log;
    log.push_back(truth(kT0, {fruit(0, a, sim_fruit_truth_t::ON_TREE, 0)}));
    log.push_back(status(kT0, "IDLE"));
    log.push_back(status(kT0 + 500'000, "ORIENT"));
    log.push_back(status(kT0 + 1'500'000, "ORIENT"));  // the same state again: still ORIENT
    log.push_back(status(kT0 + 2'500'000, "APPROACH"));
    log.push_back(status(kT0 + 3'000'000, "GRASP"));
    log.push_back(status(kT0 + 3'250'000, "ORIENT"));  // a state seen before adds to its time
    log.push_back(status(kT0 + 4'000'000, "DONE"));
    log.push_back(status(kT0 + 9'000'000, "DONE"));
    log.push_back(truth(kT0 + 9'000'000, {fruit(0, a, sim_fruit_truth_t::PICKED, kT0 + 3'200'000)}));
    evaluate_run(log, scenario, run, e);
  }
  finish(e);
  const std::vector<std::pair<std::string, double>> want{
      {"IDLE", 1.0}, {"ORIENT", 2 * 2.75}, {"APPROACH", 1.0}, {"GRASP", 0.5}, {"DONE", 10.0}};
  ASSERT_EQ(e.state_time_s.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(e.state_time_s[i].first, want[i].first);
    EXPECT_NEAR(e.state_time_s[i].second, want[i].second, 1e-9) << want[i].first;
  }
  const auto j = rt::Json::parse(to_json(e));
  EXPECT_EQ(j["state_time_s"]["ORIENT"], 5.5) << to_json(e);
  // 7 s of work for 2 picks: ORIENT 5.5 s is 78.6 %, 2.75 s per pick.
  const std::string table = to_table(e);
  EXPECT_NE(table.find("without IDLE and DONE: 7.0 s, 3.50 s per fruit picked"), std::string::npos) << table;
  EXPECT_NE(table.find("ORIENT          5.50 s   78.6 %  2.75 s per pick"), std::string::npos) << table;
  EXPECT_EQ(table.find("  IDLE "), std::string::npos) << table;
}

TEST(Evaluation, ALogWithoutGroundTruthIsRefused) {
  const Scenario scenario = load_scenario("config/scenarios/experiment1.yaml");
  Evaluation e;
  EXPECT_THROW(evaluate_run({}, scenario, 3, e), std::runtime_error);
}

}  // namespace
}  // namespace harvest::sim
