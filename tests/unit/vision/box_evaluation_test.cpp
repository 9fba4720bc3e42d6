// Scoring detections against annotated boxes (harvest-detect --evaluate), and
// the shipped detector configurations load without unknown keys.
#include "vision/box_evaluation.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "config/config.hpp"
#include "test_support.hpp"
#include "vision/detector_node.hpp"

namespace ht = harvest::testing;

namespace harvest::vision {
namespace {

DetectionBox det(double u, double v, double half) { return {u, v, {u - half, v - half, u + half, v + half}}; }

TEST(Evaluation, IntersectionOverUnion) {
  EXPECT_DOUBLE_EQ(iou({0, 0, 10, 10}, {0, 0, 10, 10}), 1.0);
  EXPECT_DOUBLE_EQ(iou({0, 0, 10, 10}, {5, 0, 15, 10}), 50.0 / 150.0);
  EXPECT_DOUBLE_EQ(iou({0, 0, 10, 10}, {20, 20, 30, 30}), 0.0);
}

TEST(Evaluation, CentreInsideOrIouMatchesOneToOne) {
  const std::vector<BoxF> boxes = {{0, 0, 100, 100}, {200, 0, 300, 100}};
  // Centre inside box 0 (small box, IoU tiny) -> match.
  EXPECT_EQ(match_boxes({det(50, 50, 5)}, boxes), std::vector<int>{0});
  // Centre outside, IoU 0.31 with box 1 -> match; IoU 0.08 -> no match.
  EXPECT_EQ(match_boxes({det(302, 50, 60)}, boxes)[0], 1);
  EXPECT_EQ(match_boxes({det(330, 50, 45)}, boxes)[0], -1);
  // Two detections in one box: one true positive, the other unmatched; the
  // better one (centre inside and larger overlap) takes it.
  const auto m = match_boxes({det(20, 20, 10), det(50, 50, 50)}, boxes);
  EXPECT_EQ(m, (std::vector<int>{-1, 0}));
  // One detection covering two boxes takes only one.
  const auto m2 = match_boxes({det(100, 50, 50), det(400, 50, 5)}, {{0, 0, 100, 100}, {100, 0, 200, 100}});
  EXPECT_TRUE(m2[0] == 0 || m2[0] == 1);
  EXPECT_EQ(m2[1], -1);
  EXPECT_TRUE(match_boxes({}, boxes).empty());
  EXPECT_EQ(match_boxes({det(1, 1, 1)}, {}), std::vector<int>{-1});
}

TEST(Evaluation, FittedCircleStandsForTheFruit) {
  Fruit f;
  f.u = 100;
  f.v = 50;
  f.diameter_px = 40;
  f.bbox = cv::Rect(80, 30, 40, 25);  // cut by a leaf
  EXPECT_DOUBLE_EQ(detection_box(f).box.y2, 55);
  f.circle_fitted = true;
  EXPECT_DOUBLE_EQ(detection_box(f).box.y2, 70);
  EXPECT_DOUBLE_EQ(detection_box(f).box.x1, 80);
}

TEST(Evaluation, ReadsBoxesCsvGroupedByImage) {
  ht::TempDir dir;
  std::ofstream(dir / "b.csv") << "image,img_w,img_h,x1,y1,x2,y2\r\nx.png,10,10,1,2,3,4\ny.png,10,10,0,0,5,5\n"
                               << "x.png,10,10,5,6,7,8\n";
  const auto a = read_boxes_csv(dir / "b.csv");
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].first, "x.png");
  ASSERT_EQ(a[0].second.size(), 2u);
  EXPECT_DOUBLE_EQ(a[0].second[1].x1, 5);
  EXPECT_DOUBLE_EQ(a[0].second[0].y2, 4);
  EXPECT_EQ(a[1].second.size(), 1u);
  std::ofstream(dir / "bad.csv") << "image,img_w,img_h,x1,y1,x2,y2\nx.png,10,10,a,2,3,4\n";
  try {
    read_boxes_csv(dir / "bad.csv");
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_boxes_csv(dir / "none.csv"), std::runtime_error);
}

// Rendered frames add a visible share (harvest-sim-frames); a fruit less than
// half visible is neither found nor missed.
TEST(Evaluation, AHalfHiddenFruitIsNeitherFoundNorMissed) {
  ht::TempDir dir;
  std::ofstream(dir / "v.csv") << "image,img_w,img_h,x1,y1,x2,y2,visible\nr.jpg,320,240,0,0,10,10,0.9\n"
                               << "r.jpg,320,240,20,0,30,10,0.3\nr.jpg,320,240,40,0,50,10,0.7\n";
  const auto a = read_boxes_csv(dir / "v.csv");
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(a[0].second.size(), 3u);
  EXPECT_DOUBLE_EQ(a[0].second[1].visible, 0.3);
  const auto& boxes = a[0].second;
  // On the visible one, on the hidden one, on nothing; the third box missed.
  const EvalCounts c = score_matches({0, 1, -1}, boxes);
  EXPECT_EQ(c.boxes, 2);
  EXPECT_EQ(c.detections, 2);
  EXPECT_EQ(c.true_positives, 1);
  EXPECT_DOUBLE_EQ(c.recall(), 0.5);
  EXPECT_DOUBLE_EQ(c.precision(), 0.5);
  // A photo's boxes (no column) all count.
  EXPECT_EQ(score_matches({0, -1}, {{0, 0, 10, 10}, {20, 0, 30, 10}}).boxes, 2);
  std::ofstream(dir / "bad.csv") << "image,img_w,img_h,x1,y1,x2,y2,visible\nr.jpg,320,240,0,0,10,10,1.5\n";
  EXPECT_THROW(read_boxes_csv(dir / "bad.csv"), std::runtime_error);
}

TEST(ShippedConfig, DetectorFilesLoadWithoutUnknownKeys) {
  for (const char* cam : {"fixed", "hand"}) {
    auto ddoc = config::Document::load_file(std::string("config/vision/detector-") + cam + ".yaml");
    const DetectorNodeConfig d = DetectorNodeConfig::from_yaml(ddoc.root());
    EXPECT_NO_THROW(ddoc.check_unused());
    EXPECT_EQ(d.calibration.width, 640);
    EXPECT_DOUBLE_EQ(d.calibration.fx, 833.57);
    EXPECT_TRUE(d.detector.circle_fit);  // canopy mode
    EXPECT_EQ(d.detector.thresholds.cb_min, -220);
  }
  auto photos = config::Document::load_file("config/vision/detector-photos.yaml");
  const DetectorNodeConfig p = DetectorNodeConfig::from_yaml(photos.root());
  EXPECT_NO_THROW(photos.check_unused());
  EXPECT_EQ(p.detector.mode, DetectorConfig::Mode::learned);  // the colour keys serve --set detector.mode=canopy
  EXPECT_EQ(p.detector.learned.model.filename(), "fruit_net_x4.onnx");  // the merged ensemble, found and loaded
  EXPECT_EQ(p.detector.thresholds.cr_max, 150);
  EXPECT_EQ(p.detector.min_area_px, 400);
}

}  // namespace
}  // namespace harvest::vision
