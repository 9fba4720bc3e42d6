// harvest-ir-calibrate as a process: fits the shipped bench CSV into a curve
// the bridge loads, and names the file and line of bad input.
#include <gtest/gtest.h>

#include <fstream>

#include "config/config.hpp"
#include "endeffector/ir_calibration.hpp"
#include "test_support.hpp"

namespace ee = harvest::endeffector;
namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace {

struct ToolRun {
  int code;
  std::string output;
};

ToolRun run_tool(const ht::TempDir& dir, const std::vector<std::string>& args) {
  std::vector<std::string> argv{ht::bin("harvest-ir-calibrate")};
  argv.insert(argv.end(), args.begin(), args.end());
  ht::ChildProcess p(argv, dir / "tool.txt");
  const int code = p.wait(20s);
  return {code, p.output()};
}

}  // namespace

TEST(EeIrCalibrateTool, FitsTheBenchCsvIntoAFileTheBridgeLoads) {
  ht::TempDir dir;
  const auto out = dir / "ir_calibration.yaml";
  const ToolRun r = run_tool(
      dir, {ht::source_path("config/endeffector/ir_calibration_points.csv"), "--bins", "12", "-o", out.string()});
  ASSERT_EQ(r.code, 0) << r.output;
  auto doc = harvest::config::Document::load_file(out);
  const ee::IrCurve c = ee::IrCurve::from_config(doc.root());
  EXPECT_NO_THROW(doc.check_unused());
  EXPECT_LE(c.knots().size(), 12u);
  EXPECT_GE(c.knots().size(), 10u);
  // 26000 / (100 + 4) = 250 counts is 100 mm on the bench sensor.
  EXPECT_NEAR(c.evaluate(250).distance_m, 0.100, 0.006);
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("# fitted from 195 rows of"), std::string::npos) << text;
}

TEST(EeIrCalibrateTool, BadCsvIsAClearErrorNamingFileAndLine) {
  ht::TempDir dir;
  const auto csv = dir / "bench.csv";
  std::ofstream(csv) << "raw,distance_m\n767.7,0.030\n481.2;0.050\n";
  const ToolRun r = run_tool(dir, {csv.string()});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("harvest-ir-calibrate: " + csv.string() + ":3: expected 'raw,distance_m'"), std::string::npos)
      << r.output;

  const ToolRun missing = run_tool(dir, {(dir / "nope.csv").string()});
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.output.find("nope.csv: cannot open"), std::string::npos) << missing.output;

  std::ofstream(csv) << "100,0.2\n100,0.3\n";
  const ToolRun flat = run_tool(dir, {csv.string()});
  EXPECT_EQ(flat.code, 2);
  EXPECT_NE(flat.output.find("same raw value"), std::string::npos) << flat.output;
}
