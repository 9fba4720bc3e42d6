#include "sim/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "harvest/harvest_status_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/json.hpp"
#include "sim/sim_node.hpp"

namespace harvest::sim {
namespace {

constexpr double kMatchRadius = 0.15;  // a report within this of a true fruit is about that fruit [m]

Vec3 vec(const double a[3]) { return Vec3(a[0], a[1], a[2]); }

Placement placement(const pose_t& p) {
  const Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
  return {q.normalized().toRotationMatrix(), vec(p.position)};
}

const char* outcome_name(int8_t state) {
  switch (state) {
    case sim_fruit_truth_t::ON_TREE:
      return "on tree";
    case sim_fruit_truth_t::HELD:
      return "held";
    case sim_fruit_truth_t::PICKED:
      return "picked";
    case sim_fruit_truth_t::KNOCKED:
      return "knocked off";
  }
  return "unknown";
}

// Index of the true fruit nearest p within kMatchRadius, -1 if none.
int nearest_fruit(const sim_truth_t& truth, const Vec3& p) {
  int best = -1;
  double best_d = kMatchRadius;
  for (std::size_t i = 0; i < truth.fruits.size(); ++i) {
    const double d = (vec(truth.fruits[i].position_base) - p).norm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(i);
    }
  }
  return best;
}

std::vector<DepthBin> bin(std::vector<std::pair<double, double>> samples) {
  std::vector<DepthBin> bins;
  if (samples.empty()) return bins;
  std::sort(samples.begin(), samples.end());
  constexpr double kWidth = 0.1;
  std::map<int, std::vector<double>> by_bin;
  for (const auto& [depth, error] : samples) by_bin[static_cast<int>(std::floor(depth / kWidth))].push_back(error);
  for (const auto& [k, errors] : by_bin) {
    DepthBin b;
    b.from_m = k * kWidth;
    b.to_m = (k + 1) * kWidth;
    b.samples = static_cast<int>(errors.size());
    double sum = 0, sum2 = 0;
    for (double e : errors) {
      sum += e;
      sum2 += e * e;
    }
    b.mean_error_m = sum / b.samples;
    b.rms_error_m = std::sqrt(sum2 / b.samples);
    bins.push_back(b);
  }
  return bins;
}

std::string number(double v, int decimals = 3) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

void add_state_time(Evaluation& e, const std::string& state, int64_t us) {
  auto it = std::find_if(e.state_time_s.begin(), e.state_time_s.end(), [&](const auto& p) { return p.first == state; });
  if (it == e.state_time_s.end()) it = e.state_time_s.insert(it, {state, 0.0});
  it->second += static_cast<double>(us) * 1e-6;
}

// States that are not part of a harvest's work (waiting to start, finished).
bool idle_state(const std::string& s) { return s == "IDLE" || s == "DONE"; }

}  // namespace

void evaluate_run(const std::vector<rt::LogRecord>& log, const Scenario& scenario, int run, Evaluation& e) {
  std::vector<sim_truth_t> truths;
  std::optional<harvest_status_t> last_status;
  int64_t last_status_time = 0;
  std::vector<targets_t> targets;
  // Every controller outcome with the log time it was first reported.
  std::vector<std::pair<int64_t, fruit_outcome_t>> reported;
  std::set<std::tuple<int32_t, int8_t, float, std::string>> seen;
  for (const auto& rec : log) {
    if (rec.channel == kSimTruthChannel) {
      if (auto m = rt::decode<sim_truth_t>(rec.data)) truths.push_back(std::move(*m));
    } else if (rec.channel == channels::kHarvestStatus) {
      if (auto m = rt::decode<harvest_status_t>(rec.data)) {
        if (last_status) add_state_time(e, last_status->state, rec.timestamp - last_status_time);
        last_status_time = rec.timestamp;
        for (const auto& o : m->outcomes)
          if (seen.emplace(o.fruit_id, o.outcome, o.cycle_time_s, o.detail).second)
            reported.emplace_back(rec.timestamp, o);
        last_status = std::move(*m);
      }
    } else if (rec.channel == channels::kTargets) {
      if (auto m = rt::decode<targets_t>(rec.data)) targets.push_back(std::move(*m));
    }
  }
  if (truths.empty()) throw std::runtime_error("run " + std::to_string(run) + ": the log has no SIM_TRUTH messages");
  if (!last_status) e.warnings.push_back("run " + std::to_string(run) + ": no HARVEST_STATUS in the log");
  const sim_truth_t& first = truths.front();
  const sim_truth_t& last = truths.back();
  if (e.scenario.empty()) e.scenario = last.scenario;
  e.runs += 1;
  e.sim_duration_s += (last.header.utime - first.header.utime) * 1e-6;
  RunFigures rf;
  rf.run = run;
  rf.seed = scenario.seed;
  rf.sim_duration_s = (last.header.utime - first.header.utime) * 1e-6;
  e.per_run.push_back(rf);

  std::vector<FruitResult> results;
  for (const auto& f : last.fruits) {
    FruitResult r;
    r.run = run;
    r.sim_id = f.sim_id;
    r.reachable = f.reachable;
    r.visible_fraction = f.visible_fraction_fixed;
    r.counted = f.reachable && f.visible_fraction_fixed >= 0.5f;
    r.outcome = outcome_name(f.state);
    r.true_position = vec(first.fruits[static_cast<std::size_t>(f.sim_id)].position_base);
    if (f.grasp_attempts > 0) {
      r.final_offset = vec(f.grasp_offset_base);
      r.final_tool = r.true_position - *r.final_offset;
    }
    results.push_back(r);
  }
  // Cycle times: the controller's own. A pick it reports is the fruit the
  // simulator saw detached last before the report (the report comes at the
  // release, after the drop; neither the tool position then nor the
  // controller's estimate of the fruit is a reliable guide); other outcomes
  // are matched by the controller's estimate. A picked fruit without a
  // controller report gets the time since the previous decision (or the start).
  std::vector<bool> matched(last.fruits.size(), false);
  for (const auto& [time, o] : reported) {
    int i = -1;
    if (o.outcome == fruit_outcome_t::PICKED) {
      int64_t latest = -1;
      for (std::size_t j = 0; j < last.fruits.size(); ++j) {
        const auto& f = last.fruits[j];
        if (f.state == sim_fruit_truth_t::PICKED && !matched[j] && f.outcome_utime <= time &&
            f.outcome_utime > latest) {
          latest = f.outcome_utime;
          i = static_cast<int>(j);
        }
      }
      if (i >= 0) matched[static_cast<std::size_t>(i)] = true;
    } else {
      i = nearest_fruit(first, vec(o.target_base));
    }
    if (i < 0) continue;
    results[static_cast<std::size_t>(i)].controller_fruit_id = o.fruit_id;
    if (o.outcome == fruit_outcome_t::PICKED) results[static_cast<std::size_t>(i)].cycle_time_s = o.cycle_time_s;
  }
  std::vector<std::pair<int64_t, std::size_t>> decided;
  for (std::size_t i = 0; i < last.fruits.size(); ++i)
    if (last.fruits[i].outcome_utime > 0) decided.emplace_back(last.fruits[i].outcome_utime, i);
  std::sort(decided.begin(), decided.end());
  int64_t previous = first.header.utime;
  for (const auto& [t, i] : decided) {
    if (!results[i].cycle_time_s && results[i].outcome == "picked") results[i].cycle_time_s = (t - previous) * 1e-6;
    previous = t;
  }
  e.fruit.insert(e.fruit.end(), results.begin(), results.end());

  // Depth estimates against the truth at the image time.
  const Mat3 fixed_rt = scenario.fixed_camera_truth.rotation.transpose();
  std::size_t k = 0;
  for (const auto& m : targets) {
    while (k + 1 < truths.size() && truths[k + 1].header.utime <= m.header.utime) ++k;
    const bool fixed = m.source_camera == "fixed";
    const Placement hand = placement(truths[k].hand_camera_pose);
    for (const auto& t : m.targets) {
      const int i = nearest_fruit(truths[k], vec(t.position_base));
      if (i < 0) continue;
      const Vec3 p = vec(truths[k].fruits[static_cast<std::size_t>(i)].position_base);
      const double true_depth = fixed ? (fixed_rt * (p - scenario.fixed_camera_truth.position)).z()
                                      : (hand.rotation.transpose() * (p - hand.position)).z();
      (fixed ? e.depth_samples_fixed : e.depth_samples_hand).emplace_back(true_depth, t.depth_m - true_depth);
    }
  }
}

void finish(Evaluation& e) {
  e.fruit_total = static_cast<int>(e.fruit.size());
  e.reachable = e.picked = e.picked_any = 0;
  std::vector<double> cycles, errors;
  std::vector<Vec3> tools;
  for (const auto& f : e.fruit) {
    const bool picked = f.outcome == "picked";
    e.picked_any += picked;
    if (!f.counted) continue;
    ++e.reachable;
    if (!picked) continue;
    ++e.picked;
    if (f.cycle_time_s) cycles.push_back(*f.cycle_time_s);
    if (f.final_offset) errors.push_back(f.final_offset->norm() * 1e3);
    if (f.final_tool) tools.push_back(*f.final_tool * 1e3);
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? std::nan("") : s / static_cast<double>(v.size());
  };
  auto max = [](const std::vector<double>& v) {
    return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end());
  };
  e.success_rate = e.reachable > 0 ? static_cast<double>(e.picked) / e.reachable : 0.0;
  e.time_per_pick_s = e.picked_any > 0 ? e.sim_duration_s / e.picked_any : std::nan("");
  e.mean_cycle_s = mean(cycles);
  e.max_cycle_s = max(cycles);
  e.mean_error_mm = mean(errors);
  e.max_error_mm = max(errors);
  for (int a = 0; a < 3; ++a) {
    if (tools.size() < 2) {
      e.final_tool_std_mm[static_cast<std::size_t>(a)] = std::nan("");
      continue;
    }
    double m = 0, s2 = 0;
    for (const auto& t : tools) m += t[a];
    m /= static_cast<double>(tools.size());
    for (const auto& t : tools) s2 += (t[a] - m) * (t[a] - m);
    e.final_tool_std_mm[static_cast<std::size_t>(a)] = std::sqrt(s2 / static_cast<double>(tools.size() - 1));
  }
  e.depth_fixed = bin(e.depth_samples_fixed);
  e.depth_hand = bin(e.depth_samples_hand);

  for (auto& r : e.per_run) {
    std::vector<double> run_cycles, run_errors;
    r.reachable = r.picked = r.picked_any = 0;
    for (const auto& f : e.fruit) {
      if (f.run != r.run) continue;
      const bool picked = f.outcome == "picked";
      r.picked_any += picked;
      if (!f.counted) continue;
      ++r.reachable;
      if (!picked) continue;
      ++r.picked;
      if (f.cycle_time_s) run_cycles.push_back(*f.cycle_time_s);
      if (f.final_offset) run_errors.push_back(f.final_offset->norm() * 1e3);
    }
    r.success_rate = r.reachable > 0 ? static_cast<double>(r.picked) / r.reachable : 0.0;
    r.mean_cycle_s = mean(run_cycles);
    r.mean_error_mm = mean(run_errors);
    r.max_error_mm = max(run_errors);
    r.time_per_pick_s = r.picked_any > 0 ? r.sim_duration_s / r.picked_any : std::nan("");
  }
  AcrossRuns& a = e.across_runs;
  a = AcrossRuns{};
  if (!e.per_run.empty()) {
    std::vector<double> rates;
    a.worst_success = 2.0;
    a.best_success = -1.0;
    for (const auto& r : e.per_run) {
      rates.push_back(r.success_rate);
      if (r.success_rate < a.worst_success) {
        a.worst_success = r.success_rate;
        a.worst_run = r.run;
      }
      a.best_success = std::max(a.best_success, r.success_rate);
      if (!std::isnan(r.max_error_mm)) a.worst_error_mm = std::max(a.worst_error_mm, r.max_error_mm);
    }
    a.mean_success = mean(rates);
    double s2 = 0;
    for (double x : rates) s2 += (x - a.mean_success) * (x - a.mean_success);
    a.std_success = rates.size() > 1 ? std::sqrt(s2 / static_cast<double>(rates.size() - 1)) : 0.0;
  }
}

std::string to_json(const Evaluation& e) {
  using rt::Json;
  using rt::json_number;
  auto mm3 = [](const Eigen::Vector3d& p) {
    return Json::array({json_number(p.x() * 1e3, 1), json_number(p.y() * 1e3, 1), json_number(p.z() * 1e3, 1)});
  };
  Json j;
  j["scenario"] = e.scenario;
  j["runs"] = e.runs;
  j["fruit_total"] = e.fruit_total;
  j["reachable"] = e.reachable;
  j["picked"] = e.picked;
  j["success_rate"] = json_number(e.success_rate, 4);
  j["mean_cycle_time_s"] = json_number(e.mean_cycle_s, 3);
  j["max_cycle_time_s"] = json_number(e.max_cycle_s, 3);
  j["mean_final_error_mm"] = json_number(e.mean_error_mm, 2);
  j["max_final_error_mm"] = json_number(e.max_error_mm, 2);
  j["final_position_std_mm"] = Json::array({json_number(e.final_tool_std_mm[0], 2),
                                            json_number(e.final_tool_std_mm[1], 2),
                                            json_number(e.final_tool_std_mm[2], 2)});
  j["simulated_time_s"] = json_number(e.sim_duration_s, 1);
  j["picked_any"] = e.picked_any;
  j["time_per_pick_s"] = json_number(e.time_per_pick_s, 2);
  {
    Json states = Json::object();
    for (const auto& [state, t] : e.state_time_s) states[state] = json_number(t, 2);
    j["state_time_s"] = states;
  }
  j["fruit"] = Json::array();
  for (const auto& f : e.fruit) {
    Json o;
    o["run"] = f.run;
    o["sim_id"] = f.sim_id;
    o["controller_fruit_id"] = f.controller_fruit_id;
    o["counted"] = f.counted;
    o["reachable"] = f.reachable;
    o["visible_fraction"] = json_number(f.visible_fraction, 2);
    o["outcome"] = f.outcome;
    o["cycle_time_s"] = f.cycle_time_s ? json_number(*f.cycle_time_s, 3) : Json(nullptr);
    o["final_error_mm"] = f.final_offset ? json_number(f.final_offset->norm() * 1e3, 2) : Json(nullptr);
    o["true_position_mm"] = mm3(f.true_position);
    j["fruit"].push_back(std::move(o));
  }
  j["per_run"] = Json::array();
  for (const auto& r : e.per_run) {
    Json o;
    o["run"] = r.run;
    o["seed"] = r.seed;
    o["reachable"] = r.reachable;
    o["picked"] = r.picked;
    o["picked_any"] = r.picked_any;
    o["success_rate"] = json_number(r.success_rate, 4);
    o["mean_cycle_time_s"] = json_number(r.mean_cycle_s, 3);
    o["mean_final_error_mm"] = json_number(r.mean_error_mm, 2);
    o["max_final_error_mm"] = json_number(r.max_error_mm, 2);
    o["simulated_time_s"] = json_number(r.sim_duration_s, 1);
    o["time_per_pick_s"] = json_number(r.time_per_pick_s, 2);
    j["per_run"].push_back(std::move(o));
  }
  const AcrossRuns& a = e.across_runs;
  j["across_runs"] = {{"mean_success_rate", json_number(a.mean_success, 4)},
                      {"worst_success_rate", json_number(a.worst_success, 4)},
                      {"worst_run", a.worst_run},
                      {"best_success_rate", json_number(a.best_success, 4)},
                      {"std_success_rate", json_number(a.std_success, 4)},
                      {"worst_final_error_mm", json_number(a.worst_error_mm, 2)}};
  auto bins = [&](const std::vector<DepthBin>& v) {
    Json out = Json::array();
    for (const auto& b : v)
      out.push_back({{"from_m", json_number(b.from_m, 2)},
                     {"to_m", json_number(b.to_m, 2)},
                     {"samples", b.samples},
                     {"mean_error_mm", json_number(b.mean_error_m * 1e3, 1)},
                     {"rms_error_mm", json_number(b.rms_error_m * 1e3, 1)}});
    return out;
  };
  j["depth_error_fixed"] = bins(e.depth_fixed);
  j["depth_error_hand"] = bins(e.depth_hand);
  j["warnings"] = e.warnings;
  return rt::json_pretty(j) + "\n";
}

std::string to_table(const Evaluation& e) {
  std::ostringstream o;
  char line[512];
  std::snprintf(line, sizeof line, "%-4s %-6s %-8s %-12s %-9s %-10s %-14s\n", "run", "fruit", "counted", "outcome",
                "cycle s", "error mm", "visible");
  o << line;
  for (const auto& f : e.fruit) {
    std::snprintf(line, sizeof line, "%-4d %-6d %-8s %-12s %-9s %-10s %-14s\n", f.run, f.sim_id,
                  f.counted ? "yes" : (f.reachable ? "hidden" : "far"), f.outcome.c_str(),
                  f.cycle_time_s ? number(*f.cycle_time_s, 2).c_str() : "-",
                  f.final_offset ? number(f.final_offset->norm() * 1e3, 1).c_str() : "-",
                  number(f.visible_fraction, 2).c_str());
    o << line;
  }
  std::snprintf(line, sizeof line,
                "\n%s: %d run(s), %d of %d counted fruit picked (%.0f %%), %d picked in all; cycle mean %s s max %s s; "
                "final error mean %s mm max %s mm; final position std x/y/z %s/%s/%s mm; %s s of run time per "
                "fruit picked\n",
                e.scenario.c_str(), e.runs, e.picked, e.reachable, 100.0 * e.success_rate, e.picked_any,
                number(e.mean_cycle_s, 2).c_str(), number(e.max_cycle_s, 2).c_str(), number(e.mean_error_mm, 1).c_str(),
                number(e.max_error_mm, 1).c_str(), number(e.final_tool_std_mm[0], 1).c_str(),
                number(e.final_tool_std_mm[1], 1).c_str(), number(e.final_tool_std_mm[2], 1).c_str(),
                number(e.time_per_pick_s, 1).c_str());
  o << line;
  if (e.per_run.size() > 1) {
    o << "per run (seed: picked/counted, success, mean cycle s, max error mm, run time per pick s):\n";
    for (const auto& r : e.per_run) {
      std::snprintf(line, sizeof line, "  run %-3d seed %-6llu %3d/%-3d %5.1f %%  %6s  %6s  %6s\n", r.run,
                    static_cast<unsigned long long>(r.seed), r.picked, r.reachable, 100.0 * r.success_rate,
                    number(r.mean_cycle_s, 2).c_str(), number(r.max_error_mm, 1).c_str(),
                    number(r.time_per_pick_s, 1).c_str());
      o << line;
    }
    const AcrossRuns& a = e.across_runs;
    std::snprintf(line, sizeof line,
                  "across %zu runs: success mean %.1f %%, worst %.1f %% (run %d), best %.1f %%, std %.1f points; "
                  "worst final error %s mm\n",
                  e.per_run.size(), 100.0 * a.mean_success, 100.0 * a.worst_success, a.worst_run,
                  100.0 * a.best_success, 100.0 * a.std_success, number(a.worst_error_mm, 1).c_str());
    o << line;
  }
  double working = 0.0;
  for (const auto& [state, t] : e.state_time_s)
    if (!idle_state(state)) working += t;
  if (working > 0) {
    o << "controller time by state (all runs, without IDLE and DONE: " << number(working, 1) << " s"
      << (e.picked_any > 0 ? ", " + number(working / e.picked_any, 2) + " s per fruit picked" : std::string()) << "):\n";
    for (const auto& [state, t] : e.state_time_s) {
      if (idle_state(state)) continue;
      std::snprintf(line, sizeof line, "  %-12s %7.2f s  %5.1f %%%s\n", state.c_str(), t, 100.0 * t / working,
                    e.picked_any > 0 ? ("  " + number(t / e.picked_any, 2) + " s per pick").c_str() : "");
      o << line;
    }
  }
  auto bins = [&](const char* name, const std::vector<DepthBin>& v) {
    if (v.empty()) return;
    o << "depth error, " << name << " camera (true depth bin: samples, mean, rms mm):\n";
    for (const auto& b : v) {
      std::snprintf(line, sizeof line, "  %4.0f-%4.0f mm: %5d  %7.1f  %7.1f\n", b.from_m * 1e3, b.to_m * 1e3, b.samples,
                    b.mean_error_m * 1e3, b.rms_error_m * 1e3);
      o << line;
    }
  };
  bins("fixed", e.depth_fixed);
  bins("hand", e.depth_hand);
  for (const auto& w : e.warnings) o << "warning: " << w << "\n";
  return o.str();
}

}  // namespace harvest::sim
