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
