#include "launch/guardian.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "launch/child.hpp"
#include "test_support.hpp"

namespace harvest::launch {
namespace {

using namespace std::chrono_literals;

bool alive(pid_t pid) {  // running and not a zombie
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  if (!(stat >> pid_s >> comm >> state)) return false;
  return state != "Z";
}

// A shell that ignores SIGTERM and has a child of its own; returns the
// shell (its group's leader) and the grandchild.
std::pair<pid_t, pid_t> stubborn_family() {
  const Spawned s = spawn({"/bin/sh", "-c", "trap '' TERM; sleep 300 & echo $!; wait; wait"}, {}, "");
  std::string out;
  char buf[64];
  while (out.find('\n') == std::string::npos) {
    pollfd p{s.output_fd, POLLIN, 0};
    if (poll(&p, 1, 5000) <= 0) break;
    const ssize_t n = read(s.output_fd, buf, sizeof buf);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  close(s.output_fd);
  return {s.pid, static_cast<pid_t>(std::stol(out))};
}

TEST(Guardian, KillsEveryRegisteredGroupGrandchildrenIncludedWhenTheLauncherGoes) {
  const auto [leader, grandchild] = stubborn_family();
  ASSERT_TRUE(alive(grandchild));
  pid_t guardian_pid = -1;
  {
    Guardian g(200ms);
    guardian_pid = g.pid();
    EXPECT_EQ(getpgid(guardian_pid), guardian_pid);  // its own group: a Ctrl-C to ours does not reach it
    g.watch(leader, SIGTERM);
  }  // end of file on its socket, as when the launcher is SIGKILLed
  int status = 0;
  ASSERT_EQ(waitpid(leader, &status, 0), leader);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);  // it ignored SIGTERM
  EXPECT_TRUE(testing::eventually([&] { return !alive(grandchild); }, 5s)) << "grandchild " << grandchild << " left";
}

TEST(Guardian, LeavesAForgottenGroupAlone) {
  const auto [leader, grandchild] = stubborn_family();
  {
    Guardian g(200ms);
    g.watch(leader, SIGTERM);
    g.forget(leader);
  }
  EXPECT_TRUE(alive(leader));
  EXPECT_TRUE(alive(grandchild));
  kill(-leader, SIGKILL);
  int status = 0;
  waitpid(leader, &status, 0);
}

TEST(Guardian, IgnoresSigintSentToTheLaunchersGroup) {
  const auto [leader, grandchild] = stubborn_family();
  {
    Guardian g(200ms);
    g.watch(leader, SIGTERM);
    ASSERT_EQ(kill(g.pid(), SIGINT), 0);
    std::this_thread::sleep_for(100ms);
    EXPECT_TRUE(alive(g.pid()));
  }
  int status = 0;
  waitpid(leader, &status, 0);
  EXPECT_TRUE(testing::eventually([&] { return !alive(grandchild); }, 5s));
}

}  // namespace
}  // namespace harvest::launch
