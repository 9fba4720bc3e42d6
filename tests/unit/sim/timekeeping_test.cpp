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
  const auto physics = tk.add_step("physics");
  const auto drives = tk.add_step("drives");
  for (int i = 0; i < 10; ++i) tk.step_ran(drives, i * kMs, i * kMs + 200);  // on time
  tk.step_ran(physics, 10 * kMs, 12 * kMs);                                  // 2 ms: not late
  tk.step_ran(physics, 20 * kMs, 25 * kMs);                                  // exactly the limit: not late
  tk.step_ran(physics, 30 * kMs, 67 * kMs);                                  // 37 ms late
  tk.frame(CameraId::kFixed, false);
  tk.frame(CameraId::kFixed, true);
  tk.frame(CameraId::kFixed, true);
  tk.frame(CameraId::kHand, false);

  const auto lines = tk.report(10 * rt::kSecond);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "physics steps fell behind: 1 of 3 late by more than 5 ms in the last 10 s (at most 37.0 ms)");
  EXPECT_EQ(lines[1], "camera fixed: rendering fell behind, 2 frames dropped in the last 10 s");
  // A quiet window says nothing.
  tk.step_ran(physics, 11 * rt::kSecond, 11 * rt::kSecond + kMs);
  EXPECT_TRUE(tk.report(20 * rt::kSecond).empty());

  EXPECT_EQ(tk.steps()[physics].steps, 4);
  EXPECT_EQ(tk.steps()[physics].late, 1);
  EXPECT_EQ(tk.steps()[physics].max_late, 37 * kMs);
  EXPECT_EQ(tk.steps()[drives].late, 0);
  EXPECT_EQ(tk.frames(CameraId::kFixed).dropped, 2);
  EXPECT_EQ(tk.frames(CameraId::kFixed).rendered, 1);
  EXPECT_EQ(tk.summary(20 * rt::kSecond),
            "timekeeping over 20.0 s: physics 4 steps, 1 late by more than 5 ms, at most 37.0 ms late; drives 10 "
            "steps, 0 late by more than 5 ms, at most 0.2 ms late; camera fixed 1 frames rendered, 2 dropped; camera "
            "hand 1 frames rendered, 0 dropped");
}

}  // namespace
}  // namespace harvest::sim
