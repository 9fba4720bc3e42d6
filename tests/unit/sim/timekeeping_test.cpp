// The simulator's own lateness and dropped frames: counted, reported for the
// last window only when something fell behind, and summed up at the end.
#include "sim/timekeeping.hpp"

#include <gtest/gtest.h>

namespace harvest::sim {
namespace {

constexpr rt::Micros kMs = rt::kMilli;

TEST(Timekeeping, CountsLateStepsAndReportsOnlyWhatFellBehindInTheWindow) {
  Timekeeping tk(5 * kMs);
  tk.start(0);
  // Physics every 10 ms from 10 ms, the drives every 1 ms from 0.
  const auto physics = tk.add_step("physics", 10 * kMs, 10 * kMs);
  const auto drives = tk.add_step("drives", 0, kMs);
  for (int i = 0; i < 10; ++i) tk.step_ran(drives, i * kMs + 200);  // each 0.2 ms after its time
  tk.step_ran(physics, 12 * kMs);  // 2 ms: not late
  tk.step_ran(physics, 25 * kMs);  // exactly the limit: not late
  tk.step_ran(physics, 67 * kMs);  // due at 30 ms: 37 ms late
  tk.frame(CameraId::kFixed, false);
  tk.frame(CameraId::kFixed, true);
  tk.frame(CameraId::kFixed, true);
  tk.frame(CameraId::kHand, false);

  const auto lines = tk.report(10 * rt::kSecond);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "physics steps fell behind: 1 of 3 late by more than 5 ms in the last 10 s (at most 37.0 ms, at t=0.03 s)");
  EXPECT_EQ(lines[1], "camera fixed: rendering fell behind, 2 frames dropped in the last 10 s");
  // A quiet window says nothing.
  // The runner catches up after a stall: each firing is the next due time.
  tk.step_ran(physics, 67 * kMs);  // due at 40 ms: 27 ms late
  tk.step_ran(physics, 67 * kMs);  // due at 50 ms: 17 ms late
  tk.report(11 * rt::kSecond);
  tk.step_ran(physics, 61 * kMs);  // due at 60 ms: 1 ms late
  EXPECT_TRUE(tk.report(20 * rt::kSecond).empty());

  EXPECT_EQ(tk.steps()[physics].steps, 6);
  EXPECT_EQ(tk.steps()[physics].late, 3);
  EXPECT_EQ(tk.steps()[physics].max_late, 37 * kMs);
  EXPECT_EQ(tk.steps()[drives].late, 0);
  EXPECT_EQ(tk.frames(CameraId::kFixed).dropped, 2);
  EXPECT_EQ(tk.frames(CameraId::kFixed).rendered, 1);
  EXPECT_EQ(tk.summary(20 * rt::kSecond),
            "timekeeping over 20.0 s: physics 6 steps, 3 late by more than 5 ms, at most 37.0 ms late (t=0.03 s); drives "
            "10 steps, 0 late by more than 5 ms, at most 0.2 ms late (t=0.00 s); camera fixed 1 frames rendered, 2 dropped; camera "
            "hand 1 frames rendered, 0 dropped");
}

}  // namespace
}  // namespace harvest::sim
