// The fixture every closed-loop test shares: the controller node against the
// arm and world doubles on one manual clock (sim_harness.hpp), and the checks
// the tests make of what it published.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "runtime/channels.hpp"
#include "servo/controller_node.hpp"
#include "signing.hpp"
#include "sim_harness.hpp"

namespace harvest::servo::testing {

namespace ch = harvest::channels;
constexpr rt::Micros kT0 = 1'700'000'000'000'000;

operator_command_t op(int8_t command);
emergency_stop_t estop(bool engaged, bool clear);

// One closed loop: controller, arm and world on an rt::SimRunner.
struct Loop {
  WorldSpec spec;
  ServoConfig cfg;
  rt::SimRunner bus{kT0};
  harvest::testing::RunnerClock clock{bus};
  harvest::testing::CommandSigner operator_signer{harvest::testing::kOperator, &clock};
  ServoControllerNode ctrl;
  ArmDouble arm;
  WorldDouble world;

  explicit Loop(WorldSpec s, ServoConfig c = test_config());
  double t() const { return rt::to_seconds(bus.now() - kT0); }
  void at(double s) { bus.run_until(kT0 + rt::from_seconds(s)); }
  // Operator commands and e-stops go in signed by an operator (docs/security.md).
  template <class Msg>
  void send(double s, const std::string& channel, Msg m) {
    at(s);
    m.header.utime = bus.now();
    if constexpr (std::is_same_v<Msg, operator_command_t> || std::is_same_v<Msg, emergency_stop_t>)
      m = operator_signer(m);
    bus.inject(channel, m);
  }
  void start(double s = 0.051) { send(s, ch::kOperatorCommand, op(operator_command_t::START)); }
  // Run until the machine is in `state` (or `limit` seconds); true if reached.
  bool run_until_state(State state, double limit);
  std::vector<std::pair<rt::Micros, robot_command_t>> commands() const {
    return bus.messages<robot_command_t>(ch::kRobotCommand);
  }
  std::vector<robot_command_t> commands_after(double s) const;
  const fruit_outcome_t* outcome(int id) const;
};

Eigen::Vector3d linear(const robot_command_t& c);
Eigen::Vector3d angular(const robot_command_t& c);
inline double linear_speed(const robot_command_t& c) { return linear(c).norm(); }
inline double angular_speed(const robot_command_t& c) { return angular(c).norm(); }

// Every command of a fault-free run respects the limits, and the arm never
// left the workspace. Returns the highest commanded linear speed [m/s].
double expect_within_limits(const Loop& loop);
// The outcomes of fruit `id` as published in the newest HARVEST_STATUS.
std::vector<fruit_outcome_t> published_outcomes(const Loop& loop, int id);
// Fruit `id` has exactly one published outcome, this one.
void expect_published(const Loop& loop, int id, int8_t outcome, const std::string& detail);
// Once the sequence has come to rest the commanded motion stops: the last
// command is a STOP, nothing but STOP follows, and the arm stays where it is.
// Every command of the run carried its validity window.
void expect_motion_stopped(Loop& loop);
// The run faults within 30 s with fruit 1 ABORTED ("`detail_prefix`..."):
// the arm stops at once and stays still, nothing but STOP follows, and the
// fault latches (START, ABORT, HOME, RESUME leave it) until RESET_FAULT.
void expect_fault_stops(Loop& loop, const std::string& detail_prefix);
// Whether any published HARVEST_STATUS summary contained `text`.
bool ever_noted(const Loop& loop, const std::string& text);
// The estimated fruit position an outcome was recorded with.
inline Eigen::Vector3d estimate_of(const fruit_outcome_t& o) {
  return {o.target_base[0], o.target_base[1], o.target_base[2]};
}
// The states HARVEST_STATUS went through, each change once.
std::vector<std::string> published_states(const Loop& loop);

}  // namespace harvest::servo::testing
