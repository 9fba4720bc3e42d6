// IR calibration: the curve (raw -> metres), its configuration, the CSV reader
// and the fit, checked against numbers worked out by hand.
#include "endeffector/ir_calibration.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "test_support.hpp"

namespace ee = harvest::endeffector;
namespace ht = harvest::testing;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

std::filesystem::path write(const ht::TempDir& dir, const std::string& name, const std::string& text) {
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST(EeIrCurve, InterpolatesBetweenKnotsAndFlagsBothEnds) {
  // Knots given out of order; raw 100 -> 0.30 m, 200 -> 0.20 m, 400 -> 0.05 m.
  const ee::IrCurve c({{400, 0.05}, {100, 0.30}, {200, 0.20}});
  EXPECT_EQ(c.knots().front().raw, 100);
  EXPECT_DOUBLE_EQ(c.evaluate(100).distance_m, 0.30);
  EXPECT_DOUBLE_EQ(c.evaluate(150).distance_m, 0.25);   // half-way 0.30 .. 0.20
  EXPECT_DOUBLE_EQ(c.evaluate(300).distance_m, 0.125);  // half-way 0.20 .. 0.05
  EXPECT_DOUBLE_EQ(c.evaluate(250).distance_m, 0.1625);
  EXPECT_EQ(c.evaluate(300).validity, ee::IrValidity::kValid);
  EXPECT_EQ(c.evaluate(400).validity, ee::IrValidity::kValid);
  EXPECT_EQ(c.evaluate(401).validity, ee::IrValidity::kTooNear);
  EXPECT_DOUBLE_EQ(c.evaluate(401).distance_m, 0.05);
  EXPECT_EQ(c.evaluate(99).validity, ee::IrValidity::kTooFar);
  EXPECT_DOUBLE_EQ(c.evaluate(99).distance_m, 0.30);
  // A sensor whose reading rises with distance: the ends swap meaning.
  const ee::IrCurve rising({{100, 0.05}, {900, 0.40}});
  EXPECT_EQ(rising.evaluate(50).validity, ee::IrValidity::kTooNear);
  EXPECT_EQ(rising.evaluate(950).validity, ee::IrValidity::kTooFar);
  EXPECT_DOUBLE_EQ(rising.evaluate(500).distance_m, 0.225);
}

TEST(EeIrCurve, RejectsCurvesThatCannotBeACalibration) {
  EXPECT_NE(error_of([] { ee::IrCurve({{100, 0.3}}); }).find("at least 2"), std::string::npos);
  EXPECT_NE(error_of([] { ee::IrCurve({{100, 0.3}, {100, 0.2}}); }).find("two points with raw 100"), std::string::npos);
  EXPECT_NE(error_of([] { ee::IrCurve({{100, 0.3}, {200, 0.2}, {300, 0.25}}); }).find("monotone"), std::string::npos);
  EXPECT_NE(error_of([] { ee::IrCurve({{100, 0.3}, {200, 0.0}}); }).find("distance > 0"), std::string::npos);
}

TEST(EeIrCurve, FromConfigAndBackToYaml) {
  auto doc = harvest::config::Document::load_string("points_raw: [100, 200, 400]\npoints_m: [0.30, 0.20, 0.05]\n");
  const auto c = ee::IrCurve::from_config(doc.root());
  EXPECT_DOUBLE_EQ(c.evaluate(300).distance_m, 0.125);
  auto again = harvest::config::Document::load_string(c.to_yaml());
  EXPECT_DOUBLE_EQ(ee::IrCurve::from_config(again.root()).evaluate(300).distance_m, 0.125);

  auto uneven = harvest::config::Document::load_string("points_raw: [100, 200]\npoints_m: [0.3]\n");
  const std::string e = error_of([&] { ee::IrCurve::from_config(uneven.root()); });
  EXPECT_NE(e.find("points_m"), std::string::npos) << e;
  auto bad = harvest::config::Document::load_string("points_raw: [100, 200]\npoints_m: [0.2, 0.3]\npoints_x: 1\n");
  EXPECT_NO_THROW(ee::IrCurve::from_config(bad.root()));  // rising is allowed
  auto flat = harvest::config::Document::load_string("points_raw: [100, 200]\npoints_m: [0.2, 0.2]\n");
  const std::string f = error_of([&] { ee::IrCurve::from_config(flat.root()); });
  EXPECT_NE(f.find("points_raw"), std::string::npos) << f;
  EXPECT_NE(f.find("monotone"), std::string::npos) << f;
}

TEST(EeIrFit, BinsAveragedByHand) {
  // 6 samples, 3 bins of 2: (105, 0.29), (205, 0.19), (410, 0.09).
  const std::vector<ee::IrCalSample> s = {{420, 0.08}, {100, 0.30}, {210, 0.18}, {110, 0.28}, {400, 0.10}, {200, 0.20}};
  const ee::IrCurve c = ee::fit_ir_curve(s, 3);
  ASSERT_EQ(c.knots().size(), 3u);
  EXPECT_DOUBLE_EQ(c.knots()[0].raw, 105);
  EXPECT_NEAR(c.knots()[0].distance_m, 0.29, 1e-12);
  EXPECT_DOUBLE_EQ(c.knots()[1].raw, 205);
  EXPECT_NEAR(c.knots()[1].distance_m, 0.19, 1e-12);
  EXPECT_DOUBLE_EQ(c.knots()[2].raw, 410);
  EXPECT_NEAR(c.knots()[2].distance_m, 0.09, 1e-12);
  EXPECT_NEAR(c.evaluate(155).distance_m, 0.24, 1e-12);
  EXPECT_NEAR(c.evaluate(307.5).distance_m, 0.14, 1e-12);
  // Residuals of the 4 samples inside [105, 410] (100 and 420 are outside), by hand:
  // 110: 0.285 vs 0.28 (+0.005); 200: 0.195 vs 0.20 (-0.005);
  // 210: 0.19 - 5 * 0.1 / 205 = 0.1875610 vs 0.18 (+0.0075610); 400: 0.0948780 vs 0.10 (-0.0051220).
  const ee::IrFitReport r = ee::fit_report(c, s);
  EXPECT_EQ(r.used, 4);
  EXPECT_NEAR(r.max_abs_m, 0.0075610, 1e-6);
  EXPECT_NEAR(r.rms_m, 0.0057750, 1e-6);  // sqrt((0.005^2 + 0.005^2 + 0.0075610^2 + 0.0051220^2) / 4)
}

TEST(EeIrFit, PoolsAdjacentViolatorsIntoAMonotoneCurve) {
  // One bin per sample; 300 reads farther than 200: the two pool to (250, 0.21).
  const std::vector<ee::IrCalSample> s = {{100, 0.30}, {200, 0.20}, {300, 0.22}, {400, 0.10}};
  const ee::IrCurve c = ee::fit_ir_curve(s, 4);
  ASSERT_EQ(c.knots().size(), 3u);
  EXPECT_DOUBLE_EQ(c.knots()[1].raw, 250);
  EXPECT_NEAR(c.knots()[1].distance_m, 0.21, 1e-12);
  EXPECT_NEAR(c.knots()[2].distance_m, 0.10, 1e-12);
}

TEST(EeIrFit, EqualRawValuesStayInOneBin) {
  const std::vector<ee::IrCalSample> s = {{100, 0.30}, {100, 0.32}, {100, 0.34}, {200, 0.20}};
  const ee::IrCurve c = ee::fit_ir_curve(s, 2);
  ASSERT_EQ(c.knots().size(), 2u);
  EXPECT_DOUBLE_EQ(c.knots()[0].raw, 100);
  EXPECT_NEAR(c.knots()[0].distance_m, 0.32, 1e-12);
  EXPECT_DOUBLE_EQ(c.knots()[1].raw, 200);
}

TEST(EeIrFit, RefusesDataThatGivesNoCurve) {
  EXPECT_NE(error_of([] { ee::fit_ir_curve({{100, 0.3}}); }).find("at least 2 samples"), std::string::npos);
  EXPECT_NE(error_of([] {
              ee::fit_ir_curve({{100, 0.3}, {100, 0.2}, {100, 0.1}});
            }).find("same raw"),
            std::string::npos);
  EXPECT_NE(error_of([] { ee::fit_ir_curve({{100, 0.2}, {200, 0.2}}); }).find("does not change"), std::string::npos);
}

TEST(EeIrFit, ShippedBenchDataGivesTheSensorModel) {
  // config/endeffector/ir_calibration_points.csv was measured on the simulator's
  // sensor, raw = 26000 / (range_mm + 4); the fit must recover it within 6 mm.
  const auto s = ee::read_ir_csv(ht::source_path("config/endeffector/ir_calibration_points.csv"));
  EXPECT_EQ(s.size(), 195u);
  const ee::IrCurve c = ee::fit_ir_curve(s);
  for (double mm = 40; mm <= 330; mm += 10) {
    const double raw = 26000.0 / (mm + 4.0);
    const ee::IrRange r = c.evaluate(raw);
    EXPECT_EQ(r.validity, ee::IrValidity::kValid) << mm;
    EXPECT_NEAR(r.distance_m * 1000, mm, 6.0) << "at " << mm << " mm";
  }
}

TEST(EeIrCsv, ReadsRowsCommentsAndOneHeader) {
  ht::TempDir dir;
  const auto p = write(dir, "ok.csv", "# bench 3\nraw,distance_m\n\n767.7,0.030\r\n 481.2 , 0.050\n# end\n");
  const auto s = ee::read_ir_csv(p);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_DOUBLE_EQ(s[0].raw, 767.7);
  EXPECT_DOUBLE_EQ(s[1].distance_m, 0.05);
}

TEST(EeIrCsv, BadInputNamesFileAndLine) {
  ht::TempDir dir;
  const auto check = [&](const std::string& text, const std::string& where, const std::string& what) {
    const auto p = write(dir, "bad.csv", text);
    const std::string e = error_of([&] { ee::read_ir_csv(p); });
    EXPECT_NE(e.find(p.string() + where), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  check("raw,distance_m\n100,0.3\n200;0.2\n", ":3: ", "expected 'raw,distance_m'");
  check("100,0.3\nraw,distance_m\n", ":2: ", "expected 'raw,distance_m'");  // a header only comes first
  check("100,0.3\n100,0.3,7\n", ":2: ", "two numbers");
  check("100,0.3\n200,abc\n", ":2: ", "expected");
  check("100,0.3\n-5,0.2\n", ":2: ", "raw must be in [0, 65535]");
  check("100,0.3\n200,0\n", ":2: ", "distance_m must be in (0, 10]");
  check("100,0.3\n200,nan\n", ":2: ", "distance_m");
  check("raw,distance_m\n# nothing\n", ": ", "no (raw, distance_m) rows");
  const std::string missing = error_of([&] { ee::read_ir_csv(dir / "nope.csv"); });
  EXPECT_NE(missing.find("nope.csv: cannot open"), std::string::npos) << missing;
}
