#include "vision/detect_tool.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <ostream>
#include <stdexcept>

#include "runtime/json.hpp"
#include "runtime/process_main.hpp"
#include "vision/detector_node.hpp"
#include "vision/overlay.hpp"

namespace harvest::vision {

std::string detections_json(const std::string& image, int width, int height, const Detections& d) {
  rt::Json fruits = rt::Json::array();
  for (const Fruit& f : d.fruits)
    fruits.push_back({{"u", rt::json_number(f.u, 2)},
                      {"v", rt::json_number(f.v, 2)},
                      {"diameter_px", rt::json_number(f.diameter_px, 2)},
                      {"depth_m", rt::json_number(f.depth_m, 4)},
                      {"confidence", rt::json_number(f.confidence, 3)},
                      {"selected", f.selected}});
  return rt::json_line({{"image", image}, {"width", width}, {"height", height}, {"fruits", std::move(fruits)}});
}

namespace {

// Loads the detector configuration and makes the overlay folder; false (with
// the reason on `err`) if either fails.
bool prepare(const DetectToolOptions& options, DetectorNodeConfig& config, std::ostream& err) {
  try {
    config::Document doc = rt::load_config(options.config_file, options.overrides);
    config = DetectorNodeConfig::from_yaml(doc.root());
    doc.check_unused();
  } catch (const std::exception& e) {
    err << "harvest-detect: configuration error: " << e.what() << "\n";
    return false;
  }
  if (!options.overlay_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options.overlay_dir, ec);
    if (ec || !std::filesystem::is_directory(options.overlay_dir)) {
      err << "harvest-detect: cannot create overlay folder " << options.overlay_dir.string() << "\n";
      return false;
    }
  }
  return true;
}

cv::Mat read_image(const std::string& path) {
  try {
    return cv::imread(path, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    return {};
  }
}

// Focal lengths scale with the image if it is not the calibrated size.
Detections detect_file_image(const DetectorNodeConfig& config, const cv::Mat3b& img) {
  const geometry::CameraModel& cal = config.calibration;
  const geometry::CameraModel cam = cal.zoomed(0, 0, cal.width, cal.height, img.cols, img.rows);
  FruitDetector detector(config.detector, cam.fx, cam.fy);
  return detector.detect(img);
}

bool write_overlay(const DetectToolOptions& options, const std::string& path, const cv::Mat& overlay,
                   std::ostream& err) {
  const auto file = options.overlay_dir / (std::filesystem::path(path).stem().string() + "_overlay.png");
  bool written = false;
  try {
    written = cv::imwrite(file.string(), overlay);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) err << "harvest-detect: cannot write overlay " << file.string() << "\n";
  return written;
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

std::vector<std::pair<std::string, FoldModel>> read_fold_models(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot read " + csv.string());
  std::vector<std::pair<std::string, FoldModel>> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number == 1 || line.empty()) continue;  // header image,model[,threshold]
    const std::string where = csv.string() + " line " + std::to_string(number);
    const auto comma = line.find(',');
    if (comma == std::string::npos || comma == 0 || comma + 1 == line.size())
      throw std::runtime_error(where + ": expected image,model[,threshold]");
    const auto comma2 = line.find(',', comma + 1);
    FoldModel fm;
    fm.model = line.substr(comma + 1, comma2 == std::string::npos ? std::string::npos : comma2 - comma - 1);
    if (fm.model.empty()) throw std::runtime_error(where + ": expected image,model[,threshold]");
    if (fm.model.is_relative()) fm.model = csv.parent_path() / fm.model;
    if (comma2 != std::string::npos) {
      const std::string t = line.substr(comma2 + 1);
      char* end = nullptr;
      const double v = std::strtod(t.c_str(), &end);
      if (t.empty() || *end != '\0' || !(v > 0 && v <= 1))
        throw std::runtime_error(where + ": threshold '" + t + "' is not a number in (0, 1]");
      fm.threshold = v;
    }
    out.emplace_back(line.substr(0, comma), fm);
  }
  return out;
}

int run_evaluation(const DetectToolOptions& options, std::ostream& out, std::ostream& err) {
  DetectorNodeConfig config;
  if (!prepare(options, config, err)) return 2;
  std::vector<std::pair<std::string, std::vector<BoxF>>> annotated;
  try {
    annotated = read_boxes_csv(options.evaluate_csv);
  } catch (const std::exception& e) {
    err << "harvest-detect: " << e.what() << "\n";
    return 2;
  }
  // Cross-validation: every image is scored by a model trained without it; an image without one is refused.
  std::map<std::string, FoldModel> fold_model;
  const double threshold = config.detector.learned.threshold;
  if (!options.fold_models.empty()) {
    if (config.detector.mode != DetectorConfig::Mode::learned) {
      err << "harvest-detect: --fold-models needs detector.mode learned\n";
      return 2;
    }
    try {
      for (auto& [image, model] : read_fold_models(options.fold_models)) fold_model[image] = model;
    } catch (const std::exception& e) {
      err << "harvest-detect: " << e.what() << "\n";
      return 2;
    }
    for (const auto& a : annotated)
      if (!fold_model.count(a.first)) {
        err << "harvest-detect: " << options.fold_models.string() << " names no model for " << a.first << "\n";
        return 2;
      }
  }
  const std::filesystem::path dir =
      options.images_dir.empty() ? options.evaluate_csv.parent_path() / "images" : options.images_dir;
  int rc = 0;
  EvalCounts total;
  std::vector<double> centre_errors, diameter_errors;
  for (const auto& [name, boxes] : annotated) {
    const std::string path = (dir / name).string();
    const cv::Mat img = read_image(path);
    if (img.empty()) {
      err << "harvest-detect: cannot read image " << path << "\n";
      rc = 1;
      continue;
    }
    Detections d;
    if (!fold_model.empty()) {
      const FoldModel& fm = fold_model.at(name);
      config.detector.learned.model = fm.model;
      config.detector.learned.threshold = fm.threshold.value_or(threshold);
      try {
        d = detect_file_image(config, img);
      } catch (const std::exception& e) {
        err << "harvest-detect: " << e.what() << "\n";
        return 2;
      }
    } else {
      d = detect_file_image(config, img);
    }
    std::vector<DetectionBox> dets;
    for (const Fruit& f : d.fruits) dets.push_back(detection_box(f));
    const std::vector<int> match = match_boxes(dets, boxes);
    for (std::size_t i = 0; i < match.size(); ++i) {
      if (match[i] < 0) continue;
      const BoxF& b = boxes[static_cast<std::size_t>(match[i])];
      if (b.visible < kScoredVisible) continue;
      const double side = 0.5 * ((b.x2 - b.x1) + (b.y2 - b.y1));
      centre_errors.push_back(std::hypot(d.fruits[i].u - 0.5 * (b.x1 + b.x2), d.fruits[i].v - 0.5 * (b.y1 + b.y2)) /
                              side);
      diameter_errors.push_back(std::abs(d.fruits[i].diameter_px - side) / side);
    }
    const EvalCounts image = score_matches(match, boxes);
    ++total.images;
    total.boxes += image.boxes;
    total.detections += image.detections;
    total.true_positives += image.true_positives;
    out << rt::json_line({{"image", path},
                          {"width", img.cols},
                          {"height", img.rows},
                          {"boxes", image.boxes},
                          {"fruits", dets.size()},
                          {"true_positives", image.true_positives}})
        << "\n";
    if (!options.overlay_dir.empty()) {
      cv::Mat overlay = draw_overlay(img, d);
      draw_box_evaluation(overlay, boxes, dets, match);
      if (!write_overlay(options, path, overlay, err)) rc = 1;
    }
  }
  const double p = total.precision(), r = total.recall();
  const double f1 = p + r > 0 ? 2 * p * r / (p + r) : 0.0;
  out << rt::json_line({{"summary",
                        {{"images", total.images},
                         {"boxes", total.boxes},
                         {"detections", total.detections},
                         {"true_positives", total.true_positives},
                         {"precision", rt::json_number(total.precision(), 4)},
                         {"recall", rt::json_number(total.recall(), 4)},
                         {"f1", rt::json_number(f1, 4)},
                         {"centre_error", rt::json_number(median(centre_errors), 4)},
                         {"diameter_error", rt::json_number(median(diameter_errors), 4)}}}})
      << "\n";
  out.flush();
  return rc;
}

int run_detect_tool(const DetectToolOptions& options, std::ostream& out, std::ostream& err) {
  if (!options.evaluate_csv.empty()) return run_evaluation(options, out, err);
  DetectorNodeConfig config;
  if (!prepare(options, config, err)) return 2;
  int rc = 0;
  for (const std::string& path : options.images) {
    const cv::Mat img = read_image(path);
    if (img.empty()) {
      err << "harvest-detect: cannot read image " << path << "\n";
      rc = 1;
      continue;
    }
    const Detections d = detect_file_image(config, img);
    out << detections_json(path, img.cols, img.rows, d) << "\n";
    if (!options.overlay_dir.empty() && !write_overlay(options, path, draw_overlay(img, d), err)) rc = 1;
  }
  out.flush();
  return rc;
}

}  // namespace harvest::vision