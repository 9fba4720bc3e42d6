#include "runtime/timer_queue.hpp"

#include <gtest/gtest.h>

#include <vector>

using harvest::rt::Micros;
using harvest::rt::TimerQueue;

TEST(TimerQueue, FiresInDueOrderAndRearmsFromDueTime) {
  TimerQueue q;
  std::vector<std::pair<char, Micros>> fired;
  Micros clock = 0;
  q.add(100, 100, [&] { fired.push_back({'a', clock}); });
  q.add(150, 0, [&] { fired.push_back({'b', clock}); });
  q.add(100, 50, [&] { fired.push_back({'c', clock}); });
  // Fire late: periodic timers catch up at their own due times, not at "now".
  EXPECT_EQ(q.fire_due(260, [&](Micros t, harvest::rt::TimerId) { clock = t; }), 7u);
  const std::vector<std::pair<char, Micros>> expected{{'a', 100}, {'c', 100}, {'b', 150}, {'c', 150},
                                                      {'a', 200}, {'c', 200}, {'c', 250}};
  EXPECT_EQ(fired, expected);
  EXPECT_EQ(q.next_due(), 300);
}

TEST(TimerQueue, CancelInsideCallback) {
  TimerQueue q;
  int n = 0;
  harvest::rt::TimerId id = 0;
  id = q.add(10, 10, [&] {
    if (++n == 3) q.cancel(id);
  });
  q.fire_due(1000, [](Micros, harvest::rt::TimerId) {});
  EXPECT_EQ(n, 3);
  EXPECT_FALSE(q.next_due().has_value());
}

// One callback object for a periodic timer's life: what a mutable callback
// keeps carries over from firing to firing (each firing ran a fresh copy of
// the original before, so a count kept in the lambda never advanced).
TEST(TimerQueue, APeriodicCallbackKeepsItsOwnStateAcrossFirings) {
  TimerQueue q;
  std::vector<int> seen;
  q.add(10, 10, [&seen, count = 0]() mutable { seen.push_back(++count); });
  q.fire_due(40, [](Micros, harvest::rt::TimerId) {});
  EXPECT_EQ(seen, (std::vector<int>{1, 2, 3, 4}));
}

TEST(TimerQueue, RejectsNegativePeriod) {
  TimerQueue q;
  EXPECT_THROW(q.add(0, -1, [] {}), std::invalid_argument);
}
