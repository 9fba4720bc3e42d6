#include "servo/harvest/fruit_ledger.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::servo {

const char* outcome_name(int8_t o) {
  switch (o) {
    case fruit_outcome_t::PICKED:
      return "picked";
    case fruit_outcome_t::LOST:
      return "lost";
    case fruit_outcome_t::UNREACHABLE:
      return "unreachable";
    case fruit_outcome_t::FAILED_GRASP:
      return "failed grasp";
    case fruit_outcome_t::ABORTED:
      return "aborted";
  }
  return "?";
}

int FruitLedger::attempts(int id) const {
  const auto it = attempts_.find(id);
  return it == attempts_.end() ? 0 : it->second;
}

bool FruitLedger::selectable(int id, const Eigen::Vector3d& p, const std::optional<Eigen::Vector3d>& sight) {
  auto along = [&](const Eigen::Vector3d& d) {
    return sight && std::acos(std::clamp(d.dot(*sight), -1.0, 1.0)) <= cfg_.same_sight_angle;
  };
  if (finished_.count(id)) {
    const auto at = finished_at_.find(id);
    const auto seen = finished_sight_.find(id);
    if (at == finished_at_.end() || (at->second - p).norm() <= cfg_.reused_id_distance ||
        (seen != finished_sight_.end() && along(seen->second)))
      return false;
    // Far from where this id was finished: another fruit under a reused id.
    finished_.erase(id);
    finished_at_.erase(id);
    finished_sight_.erase(id);
    attempts_.erase(id);
  }
  // The same fruit as one tried before: near where it was, or along its line of sight.
  const auto same = [&](const Tried& t) {
    return (t.at - p).norm() <= cfg_.same_fruit_distance || (t.sight && along(*t.sight));
  };
  if (attempts(id) == 0) {
    for (const Tried& t : tried_)
      if (!t.given_up && same(t)) attempts_[id] = std::max(attempts_[id], t.attempts);
  }
  if (out_of_attempts(id)) return false;
  if (std::any_of(tried_.begin(), tried_.end(), [&](const Tried& t) { return t.given_up && same(t); })) {
    finished_.insert(id);  // a fruit already given up, seen again under a new id
    finished_at_[id] = p;
    return false;
  }
  return true;
}

const fruit_outcome_t& FruitLedger::record(int8_t outcome, int id, const Eigen::Vector3d& target,
                                           const std::string& detail, double cycle_time_s,
                                           const Eigen::Vector3d& tool_position, const Fruit* fruit) {
  fruit_outcome_t o{};
  o.fruit_id = id;
  o.outcome = outcome;
  o.cycle_time_s = cycle_time_s;
  for (int i = 0; i < 3; ++i) {
    o.target_base[i] = target[i];
    o.final_tool_position[i] = tool_position[i];
  }
  o.detail = detail;
  outcomes_.push_back(o);
  switch (outcome) {
    case fruit_outcome_t::PICKED:
      ++tally_.picked;
      break;
    case fruit_outcome_t::LOST:
      ++tally_.lost;
      break;
    case fruit_outcome_t::UNREACHABLE:
      ++tally_.unreachable;
      break;
    case fruit_outcome_t::FAILED_GRASP:
      ++tally_.failed_grasp;
      break;
    default:
      ++tally_.aborted;
      break;
  }
  if (outcome == fruit_outcome_t::PICKED) {
    attempts_.erase(id);
    return outcomes_.back();
  }
  // Where the fruit was at selection (fixed camera), and its line of sight.
  const Eigen::Vector3d at = fruit ? fruit->selected_from : target;
  const std::optional<Eigen::Vector3d> sight =
      fruit && fruit->sight ? std::optional<Eigen::Vector3d>(fruit->sight->direction) : std::nullopt;
  const bool given_up = out_of_attempts(id);
  tried_.push_back({at, sight, attempts(id), given_up});
  if (given_up) {
    finished_.insert(id);
    finished_at_[id] = at;
    if (sight) finished_sight_[id] = *sight;
  }
  return outcomes_.back();
}

}  // namespace harvest::servo
