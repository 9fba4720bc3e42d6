// Closed-loop tests (closed_loop/loop.hpp): every ROBOT_COMMAND names the
// input it was computed from, so a log traces it back to a camera frame
// (harvest-log latency, docs/performance.md).
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "closed_loop/loop.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"

namespace harvest::servo::testing {
namespace {

// In the bus's order (each message handled before anything after it): a
// command carries the utime and seq of the newest TARGETS before it, through
// the whole sequence (pose goals, the visual approach, IR, grasp); before the
// first TARGETS, the newest robot state's.
TEST(ClosedLoop, EveryCommandNamesTheNewestTargetsItWasComputedWith) {
  Loop loop(experiment_one());
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  std::optional<std::pair<int64_t, int64_t>> targets, robot;
  std::string camera;  // of the newest TARGETS
  int from_targets = 0, twists_from_hand = 0;
  for (const rt::LogRecord& r : loop.bus.log()) {
    if (r.channel == ch::kTargets) {
      const auto t = rt::decode<targets_t>(r.data);
      ASSERT_TRUE(t);
      targets = {t->header.utime, t->header.seq};
      camera = t->source_camera;
    } else if (r.channel == ch::kRobotState) {
      const auto s = rt::decode<robot_state_t>(r.data);
      ASSERT_TRUE(s);
      robot = {s->header.utime, s->header.seq};
    } else if (r.channel == ch::kRobotCommand) {
      const auto c = rt::decode<robot_command_t>(r.data);
      ASSERT_TRUE(c);
      const auto expected = targets ? targets : robot;
      ASSERT_TRUE(expected) << "a command before any input";
      EXPECT_EQ(c->header.utime, expected->first) << "command seq " << c->header.seq;
      EXPECT_EQ(c->header.source_seq, expected->second) << "command seq " << c->header.seq;
      if (targets) ++from_targets;
      if (targets && c->type == robot_command_t::TYPE_TWIST && camera == "hand") ++twists_from_hand;
    }
  }
  EXPECT_GT(from_targets, 100);
  EXPECT_GT(twists_from_hand, 10);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
}

}  // namespace
}  // namespace harvest::servo::testing
