#include "demo/progress.hpp"

#include <cstdio>

namespace harvest::demo {

std::optional<std::string> Progress::on_status(const harvest_status_t& s, double elapsed_s) {
  state_ = s.state;
  if (s.state != "IDLE") started_ = true;
  char key[256];
  // `remaining` is not part of it: it follows the fixed camera's detections,
  // which flicker while nothing else changes.
  std::snprintf(key, sizeof key, "%s|%d|%d|%d|%d|%d|%d|%d", s.state.c_str(), s.current_fruit_id, s.picked, s.lost,
                s.unreachable, s.failed_grasp, s.paused, s.estop);
  if (last_ && *last_ == key) return std::nullopt;
  last_ = key;
  char line[512];
  const std::string fruit = s.current_fruit_id >= 0 ? "fruit " + std::to_string(s.current_fruit_id) : "no fruit";
  const std::string tree = on_tree_ >= 0 ? ", " + std::to_string(on_tree_) + " on the tree" : "";
  std::snprintf(line, sizeof line,
                "run %d %6.1f s  %-12s %-10s picked %d, remaining %d%s (lost %d, unreachable %d, failed %d)%s%s", run_,
                elapsed_s, s.state.c_str(), fruit.c_str(), s.picked, s.remaining, tree.c_str(), s.lost, s.unreachable,
                s.failed_grasp, s.paused ? " PAUSED" : "", s.estop ? " E-STOP" : "");
  return std::string(line);
}

void Progress::on_truth(const sim_truth_t& t) {
  int n = 0;
  for (const auto& f : t.fruits)
    if (f.state == sim_fruit_truth_t::ON_TREE) ++n;
  on_tree_ = n;
}

}  // namespace harvest::demo
