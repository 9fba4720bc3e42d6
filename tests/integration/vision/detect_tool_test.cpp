// harvest-detect on image files: one JSON line per image, overlays, an
// error naming each unreadable image with a non-zero exit while the others
// are still processed; evaluation mode against a boxes CSV.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace {

cv::Mat3b leaves(int w, int h) { return cv::Mat3b(h, w, cv::Vec3b(40, 120, 60)); }
void fruit(cv::Mat3b& img, int cx, int cy, int r) { cv::circle(img, {cx, cy}, r, cv::Scalar(30, 140, 230), -1); }

using Json = nlohmann::json;

// The JSON lines of the tool's output that have `key` at the top level.
std::vector<Json> objects_with(const std::string& text, const std::string& key) {
  std::vector<Json> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] != '{') continue;
    Json j = Json::parse(line);  // a line that starts an object and is not JSON fails the test
    if (j.contains(key)) out.push_back(std::move(j));
  }
  return out;
}

// `key` of every fruit of an image's line.
std::vector<double> of_fruits(const Json& image, const std::string& key) {
  std::vector<double> out;
  for (const auto& f : image.at("fruits")) out.push_back(f.at(key).get<double>());
  return out;
}

class DetectTool : public ::testing::Test {
 protected:
  void SetUp() override {
    cv::Mat3b a = leaves(640, 480);
    fruit(a, 200, 150, 40);
    ASSERT_TRUE(cv::imwrite((dir / "a.png").string(), a));
    cv::Mat3b b = leaves(320, 240);
    fruit(b, 80, 60, 20);
    fruit(b, 240, 180, 30);
    ASSERT_TRUE(cv::imwrite((dir / "b.jpg").string(), b, {cv::IMWRITE_JPEG_QUALITY, 95}));
    std::ofstream(dir / "broken.png") << "not an image";
  }
  int run(const std::vector<std::string>& args, std::string* output) {
    std::vector<std::string> argv{ht::bin("harvest-detect")};
    argv.insert(argv.end(), args.begin(), args.end());
    ht::ChildProcess p(argv, dir / "out.txt");
    const int rc = p.wait(20s);
    *output = p.output();
    return rc;
  }
  ht::TempDir dir;
};

TEST_F(DetectTool, JsonLinePerImageOverlaysAndErrorsForUnreadableImages) {
  const std::string a = (dir / "a.png").string(), b = (dir / "b.jpg").string(), broken = (dir / "broken.png").string(),
                    missing = (dir / "missing.png").string();
  std::string out;
  EXPECT_EQ(run({"--config", ht::source_path("config/vision/detector-fixed.yaml"), "--overlay",
                 (dir / "overlays").string(), a, broken, b, missing},
                &out),
            1)
      << out;
  EXPECT_NE(out.find("cannot read image " + broken), std::string::npos) << out;
  EXPECT_NE(out.find("cannot read image " + missing), std::string::npos) << out;
  const auto json = objects_with(out, "image");
  ASSERT_EQ(json.size(), 2u) << out;  // the readable ones, in order
  EXPECT_EQ(json[0]["image"], a);
  EXPECT_EQ(json[0]["width"], 640);
  EXPECT_EQ(json[0]["height"], 480);
  EXPECT_EQ(json[1]["image"], b);
  EXPECT_EQ(json[1]["width"], 320);
  EXPECT_EQ(json[1]["height"], 240);
  const auto u0 = of_fruits(json[0], "u"), v0 = of_fruits(json[0], "v"), d0 = of_fruits(json[0], "diameter_px");
  ASSERT_EQ(u0.size(), 1u);
  EXPECT_NEAR(u0[0], 200, 0.5);
  EXPECT_NEAR(v0[0], 150, 0.5);
  EXPECT_NEAR(d0[0], 81, 0.02 * 81);
  const auto z0 = of_fruits(json[0], "depth_m");
  ASSERT_EQ(z0.size(), 1u);
  EXPECT_NEAR(z0[0], 0.5 * (833.57 + 767.02) * 0.0725 / d0[0], 2e-4);  // eq. 6-11 at the calibrated size
  EXPECT_EQ(json[0]["fruits"][0]["selected"], true);
  const auto u1 = of_fruits(json[1], "u");
  ASSERT_EQ(u1.size(), 2u);
  EXPECT_EQ(of_fruits(json[1], "confidence").size(), 2u);
  // Exactly one fruit is the target.
  std::size_t selected = 0;
  for (const auto& f : json[1]["fruits"]) selected += f["selected"].get<bool>() ? 1 : 0;
  EXPECT_EQ(selected, 1u);

  // Overlays: the image with something drawn on it, for the readable images only.
  const cv::Mat3b overlay = cv::imread((dir / "overlays" / "a_overlay.png").string());
  ASSERT_FALSE(overlay.empty());
  EXPECT_GT(cv::norm(overlay, cv::imread(a), cv::NORM_L1), 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "overlays" / "b_overlay.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "overlays" / "broken_overlay.png"));

  EXPECT_EQ(run({a}, &out), 0) << out;  // all readable: success
  EXPECT_EQ(run({}, &out), 2) << out;   // nothing to do: usage error
}

TEST_F(DetectTool, EvaluationCountsOneToOneMatches) {
  // a.png: its fruit boxed. b.jpg: one fruit boxed, one not, and a box with no fruit.
  std::ofstream(dir / "boxes.csv") << "image,img_w,img_h,x1,y1,x2,y2\n"
                                   << "a.png,640,480,160,110,240,190\n"
                                   << "b.jpg,320,240,58,38,102,82\n"
                                   << "b.jpg,320,240,150,10,190,50\n"
                                   << "broken.png,10,10,0,0,5,5\n";
  std::string out;
  EXPECT_EQ(run({"--evaluate", (dir / "boxes.csv").string(), "--images-dir", dir.path().string()}, &out), 1) << out;
  EXPECT_NE(out.find("cannot read image " + (dir / "broken.png").string()), std::string::npos) << out;
  const auto per_image = objects_with(out, "image");
  ASSERT_EQ(per_image.size(), 2u) << out;
  EXPECT_EQ(per_image[1]["boxes"], 2) << per_image[1];
  EXPECT_EQ(per_image[1]["fruits"], 2) << per_image[1];
  EXPECT_EQ(per_image[1]["true_positives"], 1) << per_image[1];
  const auto summaries = objects_with(out, "summary");
  ASSERT_EQ(summaries.size(), 1u) << out;
  const Json& summary = summaries[0]["summary"];
  EXPECT_EQ(summary["images"], 2) << summary;
  EXPECT_EQ(summary["boxes"], 3) << summary;
  EXPECT_EQ(summary["detections"], 3) << summary;
  EXPECT_EQ(summary["true_positives"], 2) << summary;
  EXPECT_NEAR(summary["precision"].get<double>(), 2.0 / 3, 1e-4);
  EXPECT_NEAR(summary["recall"].get<double>(), 2.0 / 3, 1e-4);

  std::ofstream(dir / "bad.csv") << "image,img_w,img_h,x1,y1,x2,y2\na.png,640,480,1,2\n";
  EXPECT_EQ(run({"--evaluate", (dir / "bad.csv").string()}, &out), 2) << out;
  EXPECT_NE(out.find("bad.csv:2"), std::string::npos) << out;
}

// Cross-validation: every image is scored by the model its fold names; an
// image with no model, a missing model or a colour mode are refused (exit 2).
TEST_F(DetectTool, FoldModelsScoreEachImageWithItsOwnModel) {
  cv::Mat3b a = leaves(320, 240), b = leaves(320, 240);
  fruit(a, 100, 100, 30);
  fruit(b, 200, 120, 25);
  ASSERT_TRUE(cv::imwrite((dir / "a.png").string(), a));
  ASSERT_TRUE(cv::imwrite((dir / "b.png").string(), b));
  std::ofstream(dir / "boxes.csv") << "image,img_w,img_h,x1,y1,x2,y2\n"
                                   << "a.png,320,240,70,70,130,130\n"
                                   << "b.png,320,240,175,95,225,145\n";
  const std::string model = std::filesystem::absolute(ht::source_path("config/vision/models/fruit_net.onnx"));
  std::ofstream(dir / "folds.csv") << "image,model\na.png," << model << "\nb.png,missing.onnx\n";
  const std::vector<std::string> learned{
      "--set",        "detector.mode=learned", "--evaluate",   (dir / "boxes.csv").string(),
      "--images-dir", dir.path().string(),     "--fold-models"};
  auto with = [&](std::vector<std::string> args, const std::string& folds) {
    args.push_back((dir / folds).string());
    return args;
  };
  std::string out;
  EXPECT_EQ(run(with(learned, "folds.csv"), &out), 2) << out;  // b's model does not exist
  EXPECT_NE(out.find((dir / "missing.onnx").string()), std::string::npos) << out;

  std::ofstream(dir / "short.csv") << "image,model\na.png," << model << "\n";
  EXPECT_EQ(run(with(learned, "short.csv"), &out), 2) << out;
  EXPECT_NE(out.find("names no model for b.png"), std::string::npos) << out;

  std::ofstream(dir / "good.csv") << "image,model\na.png," << model << "\nb.png," << model << "\n";
  EXPECT_EQ(run({"--evaluate", (dir / "boxes.csv").string(), "--images-dir", dir.path().string(), "--fold-models",
                 (dir / "good.csv").string()},
                &out),
            2)
      << out;  // default mode canopy has no model
  EXPECT_NE(out.find("needs detector.mode learned"), std::string::npos) << out;
  EXPECT_EQ(run(with(learned, "good.csv"), &out), 0) << out;
  const auto summary = objects_with(out, "summary");
  ASSERT_EQ(summary.size(), 1u) << out;
  EXPECT_EQ(summary[0]["summary"]["images"], 2);
  EXPECT_TRUE(summary[0]["summary"]["f1"].is_number()) << summary[0];

  // A third column is the threshold chosen without the image's fold: 1 lets
  // nothing through; a's 0.01 keeps its fruit whatever detector.threshold says.
  std::ofstream(dir / "thresholds.csv") << "image,model,threshold\na.png," << model << ",0.01\nb.png," << model
                                        << ",1\n";
  auto strict = with(learned, "thresholds.csv");
  strict.insert(strict.end(), {"--set", "detector.threshold=1"});
  EXPECT_EQ(run(strict, &out), 0) << out;
  const auto per_image = objects_with(out, "image");
  ASSERT_EQ(per_image.size(), 2u) << out;
  EXPECT_GE(per_image[0]["fruits"], 1) << per_image[0];
  EXPECT_EQ(per_image[1]["fruits"], 0) << per_image[1];
  std::ofstream(dir / "badthreshold.csv") << "image,model,threshold\na.png," << model << ",high\n";
  EXPECT_EQ(run(with(learned, "badthreshold.csv"), &out), 2) << out;
  EXPECT_NE(out.find("badthreshold.csv line 2: threshold 'high' is not a number in (0, 1]"), std::string::npos) << out;
}

}  // namespace
