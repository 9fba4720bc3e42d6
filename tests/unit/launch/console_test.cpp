#include "launch/console.hpp"

#include <gtest/gtest.h>

#include <sstream>

namespace harvest::launch {
namespace {

TEST(Console, RendersOneRowPerProcess) {
  StatusRow a{"robot-link", "robot", "running", 1234, 2, "1", "0.3 s", "ok"};
  StatusRow b{"camera", "vision", "FAILED", -1, 3, "139", "-", ""};
  const std::string t = render_table({a, b});
  std::istringstream in(t);
  std::string header, r1, r2;
  std::getline(in, header);
  std::getline(in, r1);
  std::getline(in, r2);
  EXPECT_EQ(header.rfind("NAME", 0), 0u);
  EXPECT_NE(header.find("HEARTBEAT"), std::string::npos);
  EXPECT_EQ(r1.rfind("robot-link robot", 0), 0u);
  EXPECT_NE(r1.find("1234"), std::string::npos);
  EXPECT_NE(r2.find("FAILED"), std::string::npos);
  EXPECT_NE(r2.find("139"), std::string::npos);
  EXPECT_EQ(r2.find("-1"), std::string::npos);  // no pid shows as '-'
}

// The sheriff's table: every host's processes, HOST first, CPU and memory measured by the deputies.
TEST(Console, RowsOfSeveralHostsHaveAHostColumnAndCpuAndMemory) {
  StatusRow a{"robot-link", "robot", "running", 1234, 0, "", "0.3 s", "ok"};
  a.host = "robot";
  a.cpu_percent = 4.4;
  a.rss_bytes = 12 << 20;
  StatusRow b{"detector-hand", "vision", "DEPUTY LOST", 4310, 1, "143", "0.1 s", ""};
  b.host = "vision";
  const std::string t = render_table({a, b});
  std::istringstream in(t);
  std::string header, r1, r2;
  std::getline(in, header);
  std::getline(in, r1);
  std::getline(in, r2);
  EXPECT_EQ(header.rfind("HOST   NAME", 0), 0u) << t;
  EXPECT_NE(header.find("STATE         CPU   MEM     PID"), std::string::npos) << t;
  EXPECT_EQ(r1.rfind("robot  robot-link", 0), 0u) << t;
  EXPECT_NE(r1.find("running       4%    12 MB   1234"), std::string::npos) << t;
  EXPECT_NE(r2.find("DEPUTY LOST   -     -       4310"), std::string::npos) << t;
  // One host's own table has neither.
  a.host.clear();
  a.cpu_percent = -1;
  a.rss_bytes = -1;
  EXPECT_EQ(render_table({a}).rfind("NAME", 0), 0u);
  EXPECT_EQ(render_table({a}).find("CPU"), std::string::npos);
}

TEST(Console, PlainModePrintsLinesOnlyAndLiveModeRedrawsTheTable) {
  std::ostringstream plain;
  Console c(plain, false);
  c.table("T\n");
  c.line("cam", "hello");
  EXPECT_EQ(plain.str(), "[cam] hello\n");

  std::ostringstream tty;
  Console l(tty, true);
  l.table("T1\nT2\n");
  l.line("cam", "hello");
  EXPECT_EQ(tty.str(), "T1\nT2\n\033[2F\033[J[cam] hello\nT1\nT2\n");
}

// A harvest process's log line names its instance after time and level; the
// launcher's prefix replaces that, so the name is printed once (it was
// "[sim] 12:00:00.123 info [sim] started").
TEST(Console, AProcessNamedInItsOwnLineIsNamedOnce) {
  EXPECT_EQ(prefixed_line("sim", "05:50:23.640 info [sim] started (f48234a), pid 14559"),
            "[sim] 05:50:23.640 info started (f48234a), pid 14559");
  EXPECT_EQ(prefixed_line("robot-link", "05:50:23.640 error [robot-link] no PDO from the drive"),
            "[robot-link] 05:50:23.640 error no PDO from the drive");
  // Another name in the line, a plain line, a line naming it later: untouched.
  EXPECT_EQ(prefixed_line("sim", "05:50:23.640 info [sim-2] started"), "[sim] 05:50:23.640 info [sim-2] started");
  EXPECT_EQ(prefixed_line("crash", "crashing"), "[crash] crashing");
  EXPECT_EQ(prefixed_line("a", "hello [a] there"), "[a] hello [a] there");
  EXPECT_EQ(prefixed_line("a", ""), "[a] ");
  std::ostringstream plain;
  Console c(plain, false);
  c.line("sim", "05:50:23.640 warn [sim] late frame");
  EXPECT_EQ(plain.str(), "[sim] 05:50:23.640 warn late frame\n");
}

}  // namespace
}  // namespace harvest::launch
