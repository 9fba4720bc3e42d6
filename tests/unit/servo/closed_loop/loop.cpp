#include "closed_loop/loop.hpp"

#include <algorithm>
#include <optional>

#include "servo/geometry.hpp"

namespace harvest::servo::testing {

Loop::Loop(WorldSpec s, ServoConfig c)
    : spec(std::move(s)),
      cfg(std::move(c)),
      ctrl(cfg, harvest::testing::sim_authority(harvest::testing::kController, "")),
      arm(spec),
      world(spec, arm) {
  bus.add(ctrl);
  bus.add(arm);
  bus.add(world);
  bus.start();
}

bool Loop::run_until_state(State state, double limit) {
  while (t() < limit) {
    if (ctrl.machine().state() == state) return true;
    at(t() + 0.01);
  }
  return ctrl.machine().state() == state;
}

std::vector<robot_command_t> Loop::commands_after(double s) const {
  std::vector<robot_command_t> out;
  for (const auto& [time, c] : commands())
    if (time >= kT0 + rt::from_seconds(s)) out.push_back(c);
  return out;
}

const fruit_outcome_t* Loop::outcome(int id) const {
  for (const auto& o : ctrl.machine().outcomes())
    if (o.fruit_id == id) return &o;
  return nullptr;
}

operator_command_t op(int8_t command) {
  operator_command_t c{};
  c.header.source_seq = -1;
  c.command = command;
  c.source = "test";
  return c;
}

emergency_stop_t estop(bool engaged, bool clear) {
  emergency_stop_t e{};
  e.header.source_seq = -1;
  e.engaged = engaged;
  e.clear = clear;
  e.source = "test";
  e.reason = "test";
  return e;
}

Eigen::Vector3d linear(const robot_command_t& c) { return {c.twist.linear[0], c.twist.linear[1], c.twist.linear[2]}; }

Eigen::Vector3d angular(const robot_command_t& c) {
  return {c.twist.angular[0], c.twist.angular[1], c.twist.angular[2]};
}

double expect_within_limits(const Loop& loop) {
  double fastest = 0.0;
  std::optional<robot_command_t> previous;
  const double dv_max = loop.cfg.max_linear_accel * loop.cfg.tick_period_s + 1e-9;
  const double dw_max = loop.cfg.max_angular_accel * loop.cfg.tick_period_s + 1e-9;
  for (const auto& [time, c] : loop.commands()) {
    fastest = std::max(fastest, linear_speed(c));
    EXPECT_LE(linear_speed(c), loop.cfg.max_linear_speed + 1e-9) << "at " << time;
    EXPECT_LE(angular_speed(c), loop.cfg.max_angular_speed + 1e-9);
    EXPECT_EQ(c.validity_us, rt::from_seconds(loop.cfg.validity_s));
    if (c.type == robot_command_t::TYPE_POSE_GOAL) {
      EXPECT_GT(c.max_linear_speed, 0.0);
      EXPECT_LE(c.max_linear_speed, loop.cfg.max_linear_speed);
      EXPECT_TRUE(loop.cfg.workspace.contains(to_isometry(c.pose_goal).translation()));
    }
    // Acceleration limit between consecutive twists (a twist after anything
    // else starts from rest). Workspace clips may only slow down further.
    if (c.type == robot_command_t::TYPE_TWIST && loop.ctrl.machine().workspace_clips() == 0) {
      const bool chained = previous && previous->type == robot_command_t::TYPE_TWIST;
      const Eigen::Vector3d v0 = chained ? linear(*previous) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d w0 = chained ? angular(*previous) : Eigen::Vector3d::Zero();
      EXPECT_LE((linear(c) - v0).norm(), dv_max) << "at " << time;
      EXPECT_LE((angular(c) - w0).norm(), dw_max) << "at " << time;
    }
    previous = c;
  }
  for (const auto& [time, s] : loop.bus.messages<robot_state_t>(ch::kRobotState))
    EXPECT_TRUE(loop.cfg.workspace.contains(to_isometry(s.tool_pose).translation(), -1e-3)) << "at " << time;
  return fastest;
}

std::vector<fruit_outcome_t> published_outcomes(const Loop& loop, int id) {
  std::vector<fruit_outcome_t> out;
  const auto statuses = loop.bus.messages<harvest_status_t>(ch::kHarvestStatus);
  if (statuses.empty()) return out;
  for (const auto& o : statuses.back().second.outcomes)
    if (o.fruit_id == id) out.push_back(o);
  return out;
}

void expect_published(const Loop& loop, int id, int8_t outcome, const std::string& detail) {
  const auto published = published_outcomes(loop, id);
  ASSERT_EQ(published.size(), 1u) << "fruit " << id;
  EXPECT_EQ(published[0].outcome, outcome);
  EXPECT_EQ(published[0].detail, detail);
  EXPECT_GE(published[0].cycle_time_s, 0.0);
}

void expect_motion_stopped(Loop& loop) {
  loop.at(loop.t() + 0.1);  // the resting state's STOP goes out on the next tick
  ASSERT_FALSE(loop.commands().empty());
  EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  const double rest = loop.t();
  const Eigen::Vector3d p0 = loop.arm.tool().translation();
  loop.at(rest + 1.0);
  for (const auto& c : loop.commands_after(rest)) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
  EXPECT_LT((loop.arm.tool().translation() - p0).norm(), 1e-9);
  for (const auto& [time, c] : loop.commands()) EXPECT_EQ(c.validity_us, rt::from_seconds(loop.cfg.validity_s));
  expect_within_limits(loop);  // failure paths too: never above the limits
}

bool ever_noted(const Loop& loop, const std::string& text) {
  for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    if (st.summary.find(text) != std::string::npos) return true;
  return false;
}

std::vector<std::string> published_states(const Loop& loop) {
  std::vector<std::string> states;
  for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    if (states.empty() || states.back() != st.state) states.push_back(st.state);
  return states;
}

void expect_fault_stops(Loop& loop, const std::string& detail_prefix) {
  ASSERT_TRUE(loop.run_until_state(State::kFault, 30.0));
  rt::Micros fault_time = 0;  // when the FAULT status went out
  for (const auto& [time, s] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    if (s.state == "FAULT" && fault_time == 0) fault_time = time;
  ASSERT_NE(loop.outcome(1), nullptr);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::ABORTED);
  EXPECT_EQ(loop.outcome(1)->detail.rfind(detail_prefix, 0), 0u) << loop.outcome(1)->detail;
  const auto published = published_outcomes(loop, 1);
  ASSERT_EQ(published.size(), 1u);
  EXPECT_EQ(published[0].outcome, +fruit_outcome_t::ABORTED);
  EXPECT_EQ(published[0].detail.rfind(detail_prefix, 0), 0u) << published[0].detail;
  const Eigen::Vector3d held = loop.arm.tool().translation();
  loop.at(loop.t() + 1.0);
  EXPECT_LT((loop.arm.tool().translation() - held).norm(), 1e-9) << "the arm moved while faulted";
  expect_within_limits(loop);
  for (const auto& [time, c] : loop.commands()) EXPECT_EQ(c.validity_us, rt::from_seconds(loop.cfg.validity_s));
  const auto after = loop.commands_after(rt::to_seconds(fault_time - kT0));
  ASSERT_GE(after.size(), 40u);
  for (const auto& c : after) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kFault);
  loop.send(loop.t() + 0.001, ch::kOperatorCommand, op(operator_command_t::START));
  EXPECT_EQ(loop.ctrl.machine().state(), State::kFault) << "START must not clear a fault";
  for (int8_t c : {operator_command_t::ABORT, operator_command_t::HOME, operator_command_t::RESUME}) {
    loop.send(loop.t() + 0.001, ch::kOperatorCommand, op(c));
    EXPECT_EQ(loop.ctrl.machine().state(), State::kFault) << "command " << int(c) << " must not clear a fault";
  }
  loop.at(loop.t() + 0.1);
  EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  loop.send(loop.t() + 0.001, ch::kOperatorCommand, op(operator_command_t::RESET_FAULT));
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
}

}  // namespace harvest::servo::testing
