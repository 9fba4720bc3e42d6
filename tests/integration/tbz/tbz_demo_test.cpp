// Teach by zooming end to end (issue 17 item 1): harvest-demo runs the
// teach-by-zooming process set (config/sets/sim-tbz.yaml: the field set plus
// the feature tracker, the servo controller in approach_mode tbz) against the
// simulator on config/scenarios/tbz.yaml, headless, over real LCM. The fruit
// must be picked, and teach by zooming must have driven the approach: verified
// FEATURE_MATCHES during APPROACH, the controller's HARVEST_STATUS naming the
// TBZ arrival, and rotations commanded during APPROACH (the reconstruction
// approach never rotates the tool). The same scene without the sticker
// (config/scenarios/tbz_natural.yaml) must fall back to the 3D-reconstruction
// approach and be picked: matches verify only on the fruit's face, and a
// natural face has none (docs/teach-by-zooming.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "harvest/feature_matches_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "runtime/json.hpp"
#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace fs = std::filesystem;
namespace rt = harvest::rt;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

struct DemoRun {
  int code = -1;
  std::string output;
  rt::Json summary;
  std::vector<rt::LogRecord> log;  // every part of run 0, in order
};

DemoRun run_demo(const fs::path& dir, const std::string& scenario) {
  DemoRun r;
  const std::vector<std::string> argv = {ht::bin("harvest-demo"),
                                         "--no-plots",
                                         "--lcm-url",
                                         ht::unique_lcm_url(),
                                         "--out",
                                         (dir / "out").string(),
                                         "--summary",
                                         (dir / "summary.json").string(),
                                         "--image-rate",
                                         "2",
                                         "--set",
                                         "config/sets/sim-tbz.yaml",
                                         "--scenario",
                                         scenario};
  ht::ChildProcess p(argv, dir / "demo.txt");
  r.code = p.wait(std::chrono::seconds(300));
  r.output = p.output();
  if (fs::exists(dir / "summary.json")) r.summary = rt::Json::parse(slurp(dir / "summary.json"));
  std::vector<fs::path> parts;
  for (const auto& e : fs::directory_iterator(dir / "out"))
    if (e.path().filename().string().rfind("run0-", 0) == 0 && e.path().string().find(".lcm") != std::string::npos)
      parts.push_back(e.path());
  std::sort(parts.begin(), parts.end());
  for (const auto& part : parts)
    for (auto& rec : rt::read_log(part.string())) r.log.push_back(std::move(rec));
  std::stable_sort(r.log.begin(), r.log.end(), [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  return r;
}

// What the log says about the approach: the controller's state and status line over time.
struct Trace {
  // FEATURE_MATCHES during APPROACH once there was a desired image (before
  // the first zoomed view there is nothing to match: STATUS_NO_DESIRED).
  int matches_ok_in_approach = 0, matches_in_approach = 0, waiting_for_desired = 0;
  int rotating_commands_in_approach = 0, commands_in_approach = 0;
  std::vector<std::string> summaries;  // every distinct HARVEST_STATUS summary, in order
  bool any(const std::string& needle) const {
    return std::any_of(summaries.begin(), summaries.end(),
                       [&](const std::string& s) { return s.find(needle) != std::string::npos; });
  }
};

Trace trace(const std::vector<rt::LogRecord>& log) {
  Trace t;
  std::string state;
  for (const auto& r : log) {
    if (r.channel == "HARVEST_STATUS") {
      const auto s = rt::decode<harvest::harvest_status_t>(r.data);
      if (!s) continue;
      state = s->state;
      if (t.summaries.empty() || t.summaries.back() != s->summary) t.summaries.push_back(s->summary);
    } else if (r.channel == "FEATURE_MATCHES" && state == "APPROACH") {
      const auto m = rt::decode<harvest::feature_matches_t>(r.data);
      if (m && m->status == harvest::feature_matches_t::STATUS_NO_DESIRED) {
        ++t.waiting_for_desired;
        continue;
      }
      ++t.matches_in_approach;
      t.matches_ok_in_approach += m && m->status == harvest::feature_matches_t::STATUS_OK;
    } else if (r.channel == "ROBOT_COMMAND" && state == "APPROACH") {
      const auto c = rt::decode<harvest::robot_command_t>(r.data);
      if (!c || c->type != harvest::robot_command_t::TYPE_TWIST) continue;
      ++t.commands_in_approach;
      const auto& w = c->twist;
      t.rotating_commands_in_approach += std::hypot(w.angular[0], w.angular[1], w.angular[2]) > 0.01;
    }
  }
  return t;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += "  " + x + "\n";
  return s;
}

void print(const Trace& t) {
  std::printf(
      "APPROACH: %d of %d FEATURE_MATCHES verified (%d more before a desired image), %d of %d twists rotating\n%s",
      t.matches_ok_in_approach, t.matches_in_approach, t.waiting_for_desired, t.rotating_commands_in_approach,
      t.commands_in_approach, joined(t.summaries).c_str());
}

// In the suite (16-20 s). Its one failure in 8 runs on 2026-12-04 (5 alone,
// 3 beside two busy loops) was the controller reaching APPROACH before the
// first zoomed view: its FEATURE_MATCHES said "no desired image" and counted
// as unverified (46 of 82); they are not counted now, and the controller
// waits for the desired image desired_wait_s, not fallback_after_s.
TEST(TbzDemo, TheStickeredFruitIsPickedThroughTeachByZooming) {
  ht::TempDir dir;
  const DemoRun r = run_demo(dir.path(), "config/scenarios/tbz.yaml");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.summary["picked"], 1) << r.output;
  EXPECT_EQ(r.summary["reachable"], 1) << r.output;
  const Trace t = trace(r.log);
  print(t);
  EXPECT_GE(t.matches_ok_in_approach, 15);
  EXPECT_GE(t.matches_ok_in_approach, 0.8 * t.matches_in_approach);
  EXPECT_GE(t.rotating_commands_in_approach, 10);
  EXPECT_TRUE(t.any("teach by zooming arrived after")) << joined(t.summaries);
  EXPECT_FALSE(t.any("falling back")) << joined(t.summaries);
  int zoomed = 0;
  for (const auto& rec : r.log) zoomed += rec.channel == "CAMERA_FIXED_ZOOM";
  EXPECT_GE(zoomed, 1);
}

// Natural fruit (thesis section 5.7): no features on the peel. Before the
// face check the feature tracker verified the outline and the leaves beside
// it in 2 of 3 frames and the approach timed out (LOST after 30 s); now the
// controller says teach by zooming is impossible within fallback_after_s of
// the first zoomed view and picks the fruit by 3D reconstruction.
TEST(TbzDemo, TheNaturalFruitIsPickedAfterFallingBack) {
  ht::TempDir dir;
  const DemoRun r = run_demo(dir.path(), "config/scenarios/tbz_natural.yaml");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.summary["picked"], 1) << r.output;
  const Trace t = trace(r.log);
  print(t);
  EXPECT_TRUE(t.any("teach by zooming impossible (feature matches: ")) << joined(t.summaries);
  EXPECT_TRUE(t.any("falling back to the 3D-reconstruction approach")) << joined(t.summaries);
  EXPECT_FALSE(t.any("teach by zooming arrived")) << joined(t.summaries);
  EXPECT_FALSE(t.any("approach timed out")) << joined(t.summaries);
  EXPECT_GE(t.matches_in_approach, 1);  // it did look, against a zoomed view
  EXPECT_LT(t.matches_ok_in_approach, 0.5 * t.matches_in_approach);
}

}  // namespace
