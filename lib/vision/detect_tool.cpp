#include "vision/detect_tool.hpp"

#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>

#include "runtime/process_main.hpp"
#include "vision/nodes.hpp"

namespace harvest::vision {

namespace {

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const unsigned char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

std::string number(double v, int decimals) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

std::string detections_json(const std::string& image, int width, int height, const Detections& d) {
  std::string s = "{\"image\": " + json_string(image) + ", \"width\": " + std::to_string(width) +
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

int run_detect_tool(const DetectToolOptions& options, std::ostream& out, std::ostream& err) {
  DetectorNodeConfig config;
  try {
    config::Document doc = rt::load_config(options.config_file, options.overrides);
    config = DetectorNodeConfig::from_yaml(doc.root());
    doc.check_unused();
  } catch (const std::exception& e) {
    err << "harvest-detect: configuration error: " << e.what() << "\n";
    return 2;
  }
  if (!options.overlay_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options.overlay_dir, ec);
    if (ec || !std::filesystem::is_directory(options.overlay_dir)) {
      err << "harvest-detect: cannot create overlay folder " << options.overlay_dir.string() << "\n";
      return 2;
    }
  }
  int rc = 0;
  for (const std::string& path : options.images) {
    cv::Mat img;
    try {
      img = cv::imread(path, cv::IMREAD_COLOR);
    } catch (const cv::Exception&) {
      img.release();
    }
    if (img.empty()) {
      err << "harvest-detect: cannot read image " << path << "\n";
      rc = 1;
      continue;
    }
    // Focal lengths scale with the image if it is not the calibrated size.
    const CameraModel& cal = config.calibration;
    const CameraModel cam = cal.zoomed(0, 0, cal.width, cal.height, img.cols, img.rows);
    FruitDetector detector(config.detector, cam.fx, cam.fy);
    const Detections d = detector.detect(img);
    out << detections_json(path, img.cols, img.rows, d) << "\n";
    if (!options.overlay_dir.empty()) {
      const auto file = options.overlay_dir / (std::filesystem::path(path).stem().string() + "_overlay.png");
      bool written = false;
      try {
        written = cv::imwrite(file.string(), draw_overlay(img, d));
      } catch (const cv::Exception&) {
        written = false;
      }
      if (!written) {
        err << "harvest-detect: cannot write overlay " << file.string() << "\n";
        rc = 1;
      }
    }
  }
  out.flush();
  return rc;
}

}  // namespace harvest::vision
