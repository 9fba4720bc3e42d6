#include "vision/overlay.hpp"

#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

namespace harvest::vision {

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
    char depth[32];
    std::snprintf(depth, sizeof depth, "%.2f", f.depth_m);
    label += std::isfinite(f.depth_m) ? depth : "null";
    label += " m";
    cv::putText(out, label, c + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
    cv::putText(out, label, c + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
  }
  return out;
}

void draw_box_evaluation(cv::Mat& overlay, const std::vector<BoxF>& boxes, const std::vector<DetectionBox>& detections,
                         const std::vector<int>& match) {
  for (const BoxF& b : boxes)
    cv::rectangle(overlay, cv::Point2d(b.x1, b.y1), cv::Point2d(b.x2, b.y2), cv::Scalar(0, 255, 0), 2);
  for (std::size_t i = 0; i < detections.size(); ++i)
    if (match[i] < 0)
      cv::drawMarker(overlay, cv::Point2d(detections[i].u, detections[i].v), cv::Scalar(255, 0, 255),
                     cv::MARKER_TILTED_CROSS, 24, 2);
}

bool write_truth_overlays(const std::filesystem::path& dir, int index, const cv::Mat3b& bgr, const cv::Mat1b& mask,
                          const cv::Rect2d& roi, const Detections& detections, const std::vector<TruthFruit>& fruits,
                          int sensor_width, double min_visible, const std::vector<int>& crop, std::string& error) {
  const double sx = roi.width / bgr.cols, sy = roi.height / bgr.rows;
  cv::Mat3b canvas;
  cv::resize(bgr, canvas, cv::Size(), 2 * sx, 2 * sy, cv::INTER_NEAREST);
  const double cs = static_cast<double>(canvas.cols) / sensor_width;
  for (const auto& t : fruits) {
    const cv::Scalar col = t.visible >= min_visible ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 120, 0);
    cv::circle(canvas, cv::Point(cvRound(t.centre.x() * cs), cvRound(t.centre.y() * cs)),
               cvRound(0.5 * t.diameter_px * cs), col, 1, cv::LINE_AA);
    cv::putText(canvas, std::to_string(t.id), cv::Point(cvRound(t.centre.x() * cs), cvRound(t.centre.y() * cs)),
                cv::FONT_HERSHEY_SIMPLEX, 0.4, col, 1);
  }
  for (const auto& d : detections.fruits) {
    const double u = ((d.u + 0.5) * sx + roi.x - 0.5) * cs, v = ((d.v + 0.5) * sy + roi.y - 0.5) * cs;
    cv::circle(canvas, cv::Point(cvRound(u), cvRound(v)), cvRound(0.5 * d.diameter_px * sx * cs),
               cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
    cv::drawMarker(canvas, cv::Point(cvRound(u), cvRound(v)), cv::Scalar(255, 255, 0), cv::MARKER_CROSS, 6);
  }
  char number[16];
  std::snprintf(number, sizeof number, "%05d.png", index);
  const auto write = [&](const std::string& prefix, const cv::Mat& image) {
    const std::filesystem::path file = dir / (prefix + number);
    bool ok = false;
    try {
      ok = cv::imwrite(file.string(), image);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok) error += (error.empty() ? "cannot write " : ", ") + file.string();
    return ok;
  };
  bool ok = write("fixed_", canvas);
  // The mask: pixels outside it darkened.
  cv::Mat1b big_mask;
  cv::resize(mask, big_mask, canvas.size(), 0, 0, cv::INTER_NEAREST);
  cv::Mat3b masked;
  cv::resize(bgr, masked, canvas.size(), 0, 0, cv::INTER_NEAREST);
  masked.setTo(cv::Scalar(60, 0, 60), ~big_mask);
  ok = write("mask_", masked) && ok;
  if (crop.size() == 4) {
    const cv::Rect rc(cvRound(crop[0] * cs), cvRound(crop[1] * cs), cvRound(crop[2] * cs), cvRound(crop[3] * cs));
    cv::Mat both;
    cv::hconcat(canvas(rc), masked(rc), both);
    cv::resize(both, both, cv::Size(), 3, 3, cv::INTER_NEAREST);
    ok = write("crop_", both) && ok;
  }
  return ok;
}

}  // namespace harvest::vision
