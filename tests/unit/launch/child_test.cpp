#include "launch/child.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

namespace harvest::launch {
namespace {

std::vector<std::string> lines_of(const std::string& text, std::size_t max_line = 4096) {
  LineBuffer b(max_line);
  std::vector<std::string> out;
  auto add = [&](const std::string& l) { out.push_back(l); };
  for (char c : text) b.feed(&c, 1, add);  // byte by byte: chunking must not matter
  b.flush(add);
  return out;
}

TEST(LineBuffer, SplitsLinesAndKeepsThePartialOne) {
  EXPECT_EQ(lines_of("a\nbb\r\n\nccc"), (std::vector<std::string>{"a", "bb", "", "ccc"}));
  EXPECT_EQ(lines_of("abcdefg\n", 3), (std::vector<std::string>{"abc", "def", "g"}));
}

TEST(Child, RunsInItsOwnGroupWithEnvAndCwdAndReportsExit) {
  const Spawned s = spawn({"/bin/sh", "-c", "echo $FOO; pwd; echo err >&2; exit 7"}, {{"FOO", "bar"}}, "/tmp");
  EXPECT_EQ(getpgid(s.pid), s.pid);
  int status = 0;
  ASSERT_EQ(waitpid(s.pid, &status, 0), s.pid);
  EXPECT_EQ(exit_code_of(status), 7);
  std::string out;
  char buf[256];
  for (;;) {
    pollfd p{s.output_fd, POLLIN, 0};
    poll(&p, 1, 1000);
    const ssize_t n = read(s.output_fd, buf, sizeof buf);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  close(s.output_fd);
  EXPECT_EQ(out, "bar\n/tmp\nerr\n");
}

TEST(Child, MissingExecutableExits127WithReason) {
  const Spawned s = spawn({"/nonexistent/prog"}, {}, "");
  int status = 0;
  ASSERT_EQ(waitpid(s.pid, &status, 0), s.pid);
  EXPECT_EQ(exit_code_of(status), 127);
  char buf[256] = {};
  pollfd p{s.output_fd, POLLIN, 0};
  poll(&p, 1, 1000);
  EXPECT_GT(read(s.output_fd, buf, sizeof buf - 1), 0);
  EXPECT_NE(std::string(buf).find("cannot execute /nonexistent/prog"), std::string::npos);
  close(s.output_fd);
}

// Alive and not a zombie (an orphaned zombie may wait for a reaper that
// containers do not always have).
bool alive(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  if (!(stat >> pid_s >> comm >> state)) return false;
  return state != "Z";
}

TEST(Child, SignalGroupReachesGrandchildren) {
  const Spawned s = spawn({"/bin/sh", "-c", "sleep 30 & echo $!; wait"}, {}, "");
  std::string out;
  char buf[64];
  while (out.find('\n') == std::string::npos) {
    pollfd p{s.output_fd, POLLIN, 0};
    ASSERT_EQ(poll(&p, 1, 2000), 1);
    const ssize_t n = read(s.output_fd, buf, sizeof buf);
    ASSERT_GT(n, 0);
    out.append(buf, static_cast<std::size_t>(n));
  }
  const pid_t grandchild = std::stoi(out);
  EXPECT_TRUE(alive(grandchild));
  EXPECT_TRUE(signal_group(s.pid, SIGTERM));
  int status = 0;
  ASSERT_EQ(waitpid(s.pid, &status, 0), s.pid);
  EXPECT_EQ(exit_code_of(status), 128 + SIGTERM);
  for (int i = 0; i < 100 && alive(grandchild); ++i) usleep(10'000);
  EXPECT_FALSE(alive(grandchild));
  close(s.output_fd);
}

}  // namespace
}  // namespace harvest::launch
