// Detections drawn on images, for people to check the detector by eye
// (harvest-detect --overlay, harvest-vision-eval --overlay).
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vision/box_evaluation.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/truth_evaluation.hpp"

namespace harvest::vision {

// The image with each fruit's outline, centre, index and depth drawn on it
// (the selected fruit in red, the others in cyan).
cv::Mat draw_overlay(const cv::Mat3b& image, const Detections& d);

// Adds an evaluation to an overlay: the annotated boxes (green) and a
// magenta cross on each detection no box matched (match[i] < 0).
void draw_box_evaluation(cv::Mat& overlay, const std::vector<BoxF>& boxes, const std::vector<DetectionBox>& detections,
                         const std::vector<int>& match);

// harvest-vision-eval's pictures of frame `index` in `dir`, at twice the
// sensor resolution: fixed_NNNNN.png (true fruit green, dark green below
// min_visible; detections cyan), mask_NNNNN.png (the detector's mask, the
// rest darkened) and, with a crop rectangle (sensor px x y w h), both
// side by side 3x as crop_NNNNN.png. `bgr` and `mask` are the detector's
// image, showing sensor region `roi`. False, with `error` naming them, if
// files cannot be written.
bool write_truth_overlays(const std::filesystem::path& dir, int index, const cv::Mat3b& bgr, const cv::Mat1b& mask,
                          const cv::Rect2d& roi, const Detections& detections, const std::vector<TruthFruit>& fruits,
                          int sensor_width, double min_visible, const std::vector<int>& crop, std::string& error);

}  // namespace harvest::vision
