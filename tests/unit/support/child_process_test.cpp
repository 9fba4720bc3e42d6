// The test support's child processes (tests/support/test_support.hpp).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "test_support.hpp"

namespace ht = harvest::testing;

namespace {

// Alive and not a zombie waiting for its parent.
bool alive(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_field, comm, state;
  if (!(stat >> pid_field >> comm >> state)) return false;
  return state != "Z" && state != "X";
}

}  // namespace

// A test that aborts (a failed assertion in a thread, a sanitizer report)
// skips the destructors that stop its children; they must not run on.
TEST(ChildProcess, ChildrenOfATestThatDiesWithoutCleaningUpAreStopped) {
  ht::TempDir dir;
  const auto pid_file = dir.path() / "pid";
  const pid_t test = fork();
  ASSERT_GE(test, 0);
  if (test == 0) {
    auto* child = new ht::ChildProcess({"sleep", "60"}, dir.path() / "out.txt");
    std::ofstream(pid_file) << child->pid() << "\n";
    _exit(3);  // no destructor runs
  }
  int status = 0;
  ASSERT_EQ(waitpid(test, &status, 0), test);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3);
  pid_t child = 0;
  std::ifstream(pid_file) >> child;
  ASSERT_GT(child, 0);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (alive(child) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool still = alive(child);
  if (still) kill(child, SIGKILL);
  EXPECT_FALSE(still) << "the child " << child << " outlived its test";
}

TEST(ChildProcess, StopEndsTheChildAndReportsHowItEnded) {
  ht::TempDir dir;
  ht::ChildProcess p({"sleep", "60"}, dir.path() / "out.txt");
  EXPECT_TRUE(p.running());
  EXPECT_EQ(p.stop(), 128 + SIGTERM);
  EXPECT_FALSE(alive(p.pid()));
  ht::ChildProcess q({"sh", "-c", "echo hello; exit 4"}, dir.path() / "q.txt");
  EXPECT_EQ(q.wait(std::chrono::seconds(10)), 4);
  EXPECT_EQ(q.output(), "hello\n");
}
