#include "vision/detect_tool.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "runtime/json.hpp"
#include "runtime/process_main.hpp"
#include "vision/nodes.hpp"

namespace harvest::vision {

namespace {

std::string number(double v, int decimals) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

std::string detections_json(const std::string& image, int width, int height, const Detections& d) {
  std::string s = "{\"image\": " + rt::json_quoted(image) + ", \"width\": " + std::to_string(width) +
                  ", \"height\": " + std::to_string(height) + ", \"fruits\": [";
  for (std::size_t i = 0; i < d.fruits.size(); ++i) {
    const Fruit& f = d.fruits[i];
    if (i) s += ", ";
    s += "{\"u\": " + number(f.u, 2) + ", \"v\": " + number(f.v, 2) + ", \"diameter_px\": " + number(f.diameter_px, 2) +
         ", \"depth_m\": " + number(f.depth_m, 4) + ", \"confidence\": " + number(f.confidence, 3) +
         ", \"selected\": " + (f.selected ? "true" : "false") + "}";
  }
  return s + "]}";
}

cv::Mat draw_overlay(const cv::Mat3b& image, const Detections& d) {
  cv::Mat out = image.clone();
  const double scale = std::max(0.4, image.cols / 1000.0);
  for (std::size_t i = 0; i < d.fruits.size(); ++i) {
    const Fruit& f = d.fruits[i];
    const cv::Scalar colour = f.selected ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 255, 0);
    cv::polylines(out, std::vector<std::vector<cv::Point>>{f.outline}, true, colour, 1, cv::LINE_AA);
    if (f.circle_fitted)
      cv::circle(out, cv::Point2d(f.u, f.v), static_cast<int>(std::lround(f.diameter_px / 2)), colour, 1, cv::LINE_AA);
    const cv::Point c(static_cast<int>(std::lround(f.u)), static_cast<int>(std::lround(f.v)));
    cv::drawMarker(out, c, colour, cv::MARKER_CROSS, 10, 1);
    // Built by appends: GCC 12 warns falsely (-Wrestrict) on "literal" + std::string.
    std::string label = "#";
    label += std::to_string(i);
    label += ' ';
    label += number(f.depth_m, 2);
    label += " m";
    cv::putText(out, label, c + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(out, label, c + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
  }
  return out;
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
  const CameraModel& cal = config.calibration;
  const CameraModel cam = cal.zoomed(0, 0, cal.width, cal.height, img.cols, img.rows);
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

}  // namespace

double iou(const BoxF& a, const BoxF& b) {
  const BoxF i{std::max(a.x1, b.x1), std::max(a.y1, b.y1), std::min(a.x2, b.x2), std::min(a.y2, b.y2)};
  const double inter = i.area();
  const double uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

std::vector<int> match_boxes(const std::vector<DetectionBox>& detections, const std::vector<BoxF>& boxes,
                             double min_iou) {
  struct Pair {
    double score;
    int det, box;
  };
  std::vector<Pair> pairs;
  for (std::size_t d = 0; d < detections.size(); ++d)
    for (std::size_t b = 0; b < boxes.size(); ++b) {
      const DetectionBox& x = detections[d];
      const BoxF& y = boxes[b];
      const bool inside = x.u >= y.x1 && x.u <= y.x2 && x.v >= y.y1 && x.v <= y.y2;
      const double overlap = iou(x.box, y);
      if (inside || overlap >= min_iou)
        pairs.push_back({(inside ? 1.0 : 0.0) + overlap, static_cast<int>(d), static_cast<int>(b)});
    }
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.score > b.score; });
  std::vector<int> match(detections.size(), -1);
  std::vector<bool> taken(boxes.size(), false);
  for (const Pair& p : pairs) {
    if (match[static_cast<std::size_t>(p.det)] >= 0 || taken[static_cast<std::size_t>(p.box)]) continue;
    match[static_cast<std::size_t>(p.det)] = p.box;
    taken[static_cast<std::size_t>(p.box)] = true;
  }
  return match;
}

DetectionBox detection_box(const Fruit& f) {
  if (f.circle_fitted) {
    const double r = 0.5 * f.diameter_px;
    return {f.u, f.v, {f.u - r, f.v - r, f.u + r, f.v + r}};
  }
  return {f.u,
          f.v,
          {static_cast<double>(f.bbox.x), static_cast<double>(f.bbox.y), static_cast<double>(f.bbox.x + f.bbox.width),
           static_cast<double>(f.bbox.y + f.bbox.height)}};
}

std::vector<std::pair<std::string, std::vector<BoxF>>> read_boxes_csv(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot read " + csv.string());
  std::vector<std::pair<std::string, std::vector<BoxF>>> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || (number == 1 && line.rfind("image,", 0) == 0)) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    BoxF b{};
    try {
      if (cells.size() != 7) throw std::invalid_argument("columns");
      b = {std::stod(cells[3]), std::stod(cells[4]), std::stod(cells[5]), std::stod(cells[6])};
    } catch (const std::exception&) {
      throw std::runtime_error(csv.string() + ":" + std::to_string(number) +
                               ": expected image,img_w,img_h,x1,y1,x2,y2");
    }
    if (out.empty() || out.back().first != cells[0]) {
      auto it = std::find_if(out.begin(), out.end(), [&](const auto& e) { return e.first == cells[0]; });
      if (it == out.end()) {
        out.emplace_back(cells[0], std::vector<BoxF>{});
        it = out.end() - 1;
      }
      it->second.push_back(b);
    } else {
      out.back().second.push_back(b);
    }
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
  const std::filesystem::path dir =
      options.images_dir.empty() ? options.evaluate_csv.parent_path() / "images" : options.images_dir;
  int rc = 0;
  EvalCounts total;
  for (const auto& [name, boxes] : annotated) {
    const std::string path = (dir / name).string();
    const cv::Mat img = read_image(path);
    if (img.empty()) {
      err << "harvest-detect: cannot read image " << path << "\n";
      rc = 1;
      continue;
    }
    const Detections d = detect_file_image(config, img);
    std::vector<DetectionBox> dets;
    for (const Fruit& f : d.fruits) dets.push_back(detection_box(f));
    const std::vector<int> match = match_boxes(dets, boxes);
    const int tp = static_cast<int>(std::count_if(match.begin(), match.end(), [](int m) { return m >= 0; }));
    ++total.images;
    total.boxes += static_cast<int>(boxes.size());
    total.detections += static_cast<int>(dets.size());
    total.true_positives += tp;
    out << "{\"image\": " << rt::json_quoted(path) << ", \"width\": " << img.cols << ", \"height\": " << img.rows
        << ", \"boxes\": " << boxes.size() << ", \"fruits\": " << dets.size() << ", \"true_positives\": " << tp
        << "}\n";
    if (!options.overlay_dir.empty()) {
      cv::Mat overlay = draw_overlay(img, d);
      for (const BoxF& b : boxes)
        cv::rectangle(overlay, cv::Point2d(b.x1, b.y1), cv::Point2d(b.x2, b.y2), cv::Scalar(0, 255, 0), 2);
      for (std::size_t i = 0; i < dets.size(); ++i)
        if (match[i] < 0)
          cv::drawMarker(overlay, cv::Point2d(dets[i].u, dets[i].v), cv::Scalar(255, 0, 255), cv::MARKER_TILTED_CROSS,
                         24, 2);
      if (!write_overlay(options, path, overlay, err)) rc = 1;
    }
  }
  out << "{\"summary\": {\"images\": " << total.images << ", \"boxes\": " << total.boxes
      << ", \"detections\": " << total.detections << ", \"true_positives\": " << total.true_positives
      << ", \"precision\": " << number(total.precision(), 4) << ", \"recall\": " << number(total.recall(), 4) << "}}\n";
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
