#include "runtime/awake_clock.hpp"

#include <gtest/gtest.h>

using harvest::rt::AwakeClock;

TEST(AwakeClock, StepsUpToTheLongestCountInFull) {
  AwakeClock c(20'000);
  EXPECT_EQ(c.at(1'000'000), 1'000'000);
  EXPECT_EQ(c.at(1'010'000), 1'010'000);
  EXPECT_EQ(c.at(1'030'000), 1'030'000);  // 20 ms: the longest step, counted
  EXPECT_EQ(c.stalls(), 0);
  EXPECT_EQ(c.lost_us(), 0);
}

TEST(AwakeClock, AStallCountsOnlyTheLongestStep) {
  AwakeClock c(20'000);
  c.at(1'000'000);
  // A 150 ms freeze: 20 ms of it count, 130 ms are this process's own.
  EXPECT_EQ(c.at(1'150'000), 1'020'000);
  EXPECT_EQ(c.at(1'160'000), 1'030'000);  // and later steps count in full again
  EXPECT_EQ(c.stalls(), 1);
  EXPECT_EQ(c.lost_us(), 130'000);
  EXPECT_EQ(c.longest_lost_us(), 130'000);
  c.at(1'260'000);  // a second stall, 80 ms lost
  EXPECT_EQ(c.stalls(), 2);
  EXPECT_EQ(c.lost_us(), 210'000);
  EXPECT_EQ(c.longest_lost_us(), 130'000);
}

TEST(AwakeClock, ASilentPeerIsStillSeenAfterTheSameAwakeTime) {
  // 100 ms of silence while running at 10 ms steps: 100 ms of awake time.
  AwakeClock c(20'000);
  const int64_t heard = c.at(0);
  int64_t t = 0;
  while (c.at(t) - heard <= 100'000) t += 10'000;
  EXPECT_EQ(t, 110'000);
}

TEST(AwakeClock, NeverGoesBackAndOffIsWallTime) {
  AwakeClock c(20'000);
  c.at(500'000);
  EXPECT_EQ(c.at(490'000), 500'000);  // an older reading (a frame's transport time) does not go back
  AwakeClock off;
  EXPECT_EQ(off.at(0), 0);
  EXPECT_EQ(off.at(5'000'000), 5'000'000);
  EXPECT_EQ(off.stalls(), 0);
}
