#include "sim/training_frames.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <sstream>

#include "test_support.hpp"

namespace ht = harvest::testing;

namespace harvest::sim {
namespace {

geometry::CameraModel pinhole() {
  geometry::CameraModel m;
  m.fx = m.fy = 100;
  m.cx = 160;
  m.cy = 120;
  m.width = 320;
  m.height = 240;
  return m;
}

// Worked by hand: a sphere of radius 0.1 m, 1 m ahead, is seen under a
// half-angle asin(0.1): its box is 100 tan(asin 0.1) = 10.050 px each side.
// Moved 0.5 m right, its tangents lie at atan(0.5) +- asin(0.1 / 1.1180):
// x = 160 + 100 tan(0.55321) = 221.77 and 160 + 100 tan(0.37409) = 199.25,
// wider than a circle of the same distance (the oblique view stretches it).
TEST(TrainingFrames, ASpheresBoxIsItsLimbsProjection) {
  const FrameBox a = sphere_box(pinhole(), {0, 0, 1}, 0.1);
  EXPECT_NEAR(a.x1, 149.950, 0.01);
  EXPECT_NEAR(a.x2, 170.050, 0.01);
  EXPECT_NEAR(a.y1, 109.950, 0.01);
  EXPECT_NEAR(a.y2, 130.050, 0.01);
  const FrameBox b = sphere_box(pinhole(), {0.5, 0, 1}, 0.1);
  EXPECT_NEAR(b.x1, 199.25, 0.05);
  EXPECT_NEAR(b.x2, 221.77, 0.05);
  EXPECT_NEAR(0.5 * (b.y1 + b.y2), 120.0, 1e-6);
}

std::string read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Two scenes of the short tree, the fixed view and two hand views each:
// every box parses, is as visible as asked, and the same options give the
// same files (training must be reproducible).
TEST(TrainingFrames, RenderedFramesCarryTheirFruitAndRepeatThemselves) {
  ht::TempDir a, b;
  TrainingFramesOptions o;
  o.scenes = 2;
  o.hand_views = 2;
  o.seed = 7;
  const Scenario sc = load_scenario(ht::source_path("config/scenarios/tree_short.yaml"));
  const auto rows = render_training_frames(sc, "short", o, a.path());
  ASSERT_FALSE(rows.empty());
  int fixed = 0;
  for (const auto& r : rows) {
    std::stringstream ss(r);
    std::vector<std::string> cells;
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    ASSERT_EQ(cells.size(), 8u) << r;
    EXPECT_TRUE(std::filesystem::exists(a / ("images/" + cells[0]))) << cells[0];
    EXPECT_EQ(cells[1], "320");
    const double x1 = std::stod(cells[3]), x2 = std::stod(cells[5]), visible = std::stod(cells[7]);
    EXPECT_LT(x1, x2);
    EXPECT_GE(visible, o.min_visible);
    EXPECT_LE(visible, 1.0);
    fixed += cells[0].find("_fixed") != std::string::npos;
  }
  EXPECT_GE(fixed, 2) << "the fixed camera sees the short tree's fruit";
  EXPECT_EQ(render_training_frames(sc, "short", o, b.path()), rows);
  for (const char* image : {"short_s7_fixed.jpg", "short_s8_hand1.jpg"})
    EXPECT_EQ(read(a / ("images/" + std::string(image))), read(b / ("images/" + std::string(image)))) << image;
}

}  // namespace
}  // namespace harvest::sim
