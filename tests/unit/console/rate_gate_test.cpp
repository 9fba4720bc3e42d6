#include "runtime/rate_gate.hpp"

#include <gtest/gtest.h>

namespace harvest::rt {
namespace {

// 30 Hz for 10 s through a 5 Hz gate: 50 kept (slots, not "a period since the last", which keeps 43).
TEST(RateGate, ThirtyHertzKeptAtFiveAveragesFive) {
  RateGate gate(5.0);
  int kept = 0;
  for (int i = 0; i < 300; ++i) kept += gate.admit(static_cast<int64_t>(i * 1e6 / 30.0));
  EXPECT_EQ(kept, 50);
}

TEST(RateGate, FirstMessageAndOneAfterAGapPass) {
  RateGate gate(5.0);
  EXPECT_TRUE(gate.admit(1'000'000));
  EXPECT_FALSE(gate.admit(1'100'000));
  EXPECT_TRUE(gate.admit(5'000'000));   // after a gap: kept, and slots restart from here
  EXPECT_FALSE(gate.admit(5'150'000));  // not a burst to catch up
  EXPECT_TRUE(gate.admit(5'200'000));
}

TEST(RateGate, ZeroPassesEverythingNegativeRefused) {
  RateGate gate(0);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(gate.admit(1000));
  EXPECT_THROW(RateGate(-1), std::invalid_argument);
}

}  // namespace
}  // namespace harvest::rt
