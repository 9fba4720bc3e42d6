// SELECT: which fruit next, from the fixed camera's view.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "harvest/fruit_outcome_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/harvest/fruit_ledger.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

struct Selection {
  std::optional<Fruit> fruit;             // the fruit to go for next; nullopt: none left
  std::vector<fruit_outcome_t> rejected;  // targets recorded UNREACHABLE on the way, in order
};

// Among the view's targets the ledger lets be selected: fruit tried fewer
// times first (a fruit whose attempt failed is tried again after every
// untried one: what made it fail is often a neighbour, gone by then), then
// those whose fixed-camera estimate is pickable, then (fruit_order "cost")
// by lowest cost or ("travel", with `travel_from`) by the smallest turn from
// the tool orientation `travel_from` to the fruit's aim from home, then
// lowest id. A target whose estimate is not pickable is aimed at along its
// line of sight (depth doubtful); one with no pickable point on it is
// recorded UNREACHABLE in the ledger for good. The chosen fruit's attempt
// is not counted here. `aim_from` is where the gripper aims from (home).
Selection select_fruit(const ServoConfig& cfg, const targets_t& view, FruitLedger& ledger,
                       const Eigen::Vector3d& aim_from, rt::Micros now,
                       const std::optional<Eigen::Matrix3d>& travel_from = std::nullopt);

}  // namespace harvest::servo
