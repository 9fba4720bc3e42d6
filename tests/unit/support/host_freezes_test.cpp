#include "host_freezes.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include "runtime/clock.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;

// Worked by hand: [0,10) [5,20) [30,40) [35,38) [50,60) seen over [8, 55):
// 8..20 (12) + 30..40 (10) + 50..55 (5) = 27.
TEST(HostFreezes, OverlappingFreezesCountOnceAndOnlyInsideTheWindow) {
  const std::vector<std::pair<int64_t, int64_t>> spans{{30, 40}, {0, 10}, {50, 60}, {5, 20}, {35, 38}};
  EXPECT_EQ(ht::covered_between(spans, 8, 55), 27);
  EXPECT_EQ(ht::covered_between(spans, 20, 30), 0);
  EXPECT_EQ(ht::covered_between(spans, 0, 100), 20 + 10 + 10);
  EXPECT_EQ(ht::covered_between({}, 0, 100), 0);
}

// The whole process stopped for 80 ms by a child (SIGSTOP, SIGCONT), as a
// hypervisor freezes the machine: the probes see it.
TEST(HostFreezes, AStoppedProcessIsSeenFrozen) {
  ht::TempDir tmp;
  ht::HostFreezes host;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const int64_t from = harvest::rt::wall_time_now();
  const std::string me = std::to_string(::getpid());
  ht::ChildProcess freezer({"/bin/sh", "-c", "kill -STOP " + me + "; sleep 0.08; kill -CONT " + me},
                           tmp / "freezer.log");
  ASSERT_EQ(freezer.wait(std::chrono::seconds(10)), 0) << freezer.output();
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  const int64_t to = harvest::rt::wall_time_now();
  const int64_t frozen = host.frozen_between(from, to);
  EXPECT_GE(frozen, 60'000) << "of " << (to - from) << " us";
  EXPECT_LE(frozen, to - from);
}
