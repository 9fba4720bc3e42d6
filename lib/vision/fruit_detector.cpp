#include "vision/fruit_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "config/config.hpp"
#include "vision/circle_fit.hpp"
#include "vision/depth.hpp"

namespace harvest::vision {

DetectorConfig DetectorConfig::thesis() { return {}; }

DetectorConfig DetectorConfig::canopy() {
  DetectorConfig c;
  c.open_radius_px = 1;
  c.close_radius_px = 2;
  c.fill_holes = true;
  c.split_touching = true;
  c.reject_shapes = true;
  c.circle_fit = true;
  return c;
}

DetectorConfig DetectorConfig::from_yaml(const config::Node& n) {
  const std::string mode = n.choice("mode", "canopy", {"thesis", "canopy"});
  DetectorConfig c = mode == "thesis" ? thesis() : canopy();
  const config::Range<double> any{-1000, 1000};
  auto& t = c.thresholds;
  t.cr_min = n.get("cr_min", t.cr_min, any);
  t.cr_max = n.get("cr_max", t.cr_max, any);
  t.cg_min = n.get("cg_min", t.cg_min, any);
  t.cg_max = n.get("cg_max", t.cg_max, any);
  t.cb_min = n.get("cb_min", t.cb_min, any);
  t.cb_max = n.get("cb_max", t.cb_max, any);
  if (t.cr_min > t.cr_max) n.fail("cr_max", "a value >= cr_min");
  if (t.cg_min > t.cg_max) n.fail("cg_max", "a value >= cg_min");
  if (t.cb_min > t.cb_max) n.fail("cb_max", "a value >= cb_min");
  c.min_area_px = n.get<int64_t>("min_area_px", c.min_area_px, {0, 100'000'000});
  c.fruit_diameter_m = n.get("fruit_diameter_m", c.fruit_diameter_m, {0.01, 0.5});
  c.kr = n.get("kr", c.kr, {0.0, 1e6});
  c.kd_per_m = n.get("kd_per_m", c.kd_per_m, {0.0, 1e6});
  c.open_radius_px = n.get("open_radius_px", c.open_radius_px, {0, 50});
  c.close_radius_px = n.get("close_radius_px", c.close_radius_px, {0, 50});
  c.fill_holes = n.get("fill_holes", c.fill_holes);
  c.split_touching = n.get("split_touching", c.split_touching);
  c.split_min_radius_px = n.get("split_min_radius_px", c.split_min_radius_px, {0.5, 1000.0});
  c.split_min_peak_ratio = n.get("split_min_peak_ratio", c.split_min_peak_ratio, {0.0, 1.0});
  c.reject_shapes = n.get("reject_shapes", c.reject_shapes);
  c.min_roundness = n.get("min_roundness", c.min_roundness, {0.0, 1.0});
  c.min_solidity = n.get("min_solidity", c.min_solidity, {0.0, 1.0});
  c.max_aspect_ratio = n.get("max_aspect_ratio", c.max_aspect_ratio, {1.0, 100.0});
  c.circle_fit = n.get("circle_fit", c.circle_fit);
  c.min_visible_fraction = n.get("min_visible_fraction", c.min_visible_fraction, {0.0, 1.0});
  return c;
}

namespace {

cv::Mat disc_kernel(int radius) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
}

// Holes are background pixels not reachable from the crop border (the crop
// has a one-pixel empty frame, so flooding from (0, 0) reaches all outside).
void fill_holes(cv::Mat1b& crop) {
  cv::Mat1b outside = crop.clone();
  cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(255));
  crop |= ~outside;
}

// Outline points that are fruit edge: on the convex hull, and on a short
// hull edge (a leaf's straight border or the image border makes a long one,
// a leaf biting into the fruit makes a concavity off the hull). The hull
// vertices are outline points, in outline order, so each outline point is
// tested against the hull edge spanning it: linear in the outline length.
std::vector<cv::Point2d> fruit_edge_points(const std::vector<cv::Point>& contour, cv::Point offset, cv::Size image,
                                           double max_edge_px) {
  std::vector<cv::Point2d> edge;
  const int n = static_cast<int>(contour.size());
  if (n == 0) return edge;
  std::vector<int> hull;
  cv::convexHull(contour, hull, false, false);
  if (hull.empty()) return edge;
  std::sort(hull.begin(), hull.end());
  hull.erase(std::unique(hull.begin(), hull.end()), hull.end());
  edge.reserve(contour.size());
  const std::size_t m = hull.size();
  for (std::size_t i = 0; i < m; ++i) {
    const int from = hull[i];
    const int to = i + 1 < m ? hull[i + 1] : hull[0] + n;  // the last edge wraps around
    const cv::Point a = contour[static_cast<std::size_t>(from)], b = contour[static_cast<std::size_t>(to % n)];
    const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
    const bool short_edge = std::sqrt(len2) <= max_edge_px;
    if (!short_edge) continue;
    const double inv_len2 = len2 > 0 ? 1.0 / len2 : 0.0;
    const int last = m == 1 ? from + n - 1 : to - 1;  // points from .. to-1 belong to this edge
    for (int k = from; k <= last; ++k) {
      const cv::Point c = contour[static_cast<std::size_t>(k % n)];
      const cv::Point q = c + offset;
      if (q.x <= 0 || q.y <= 0 || q.x >= image.width - 1 || q.y >= image.height - 1) continue;
      const double px = c.x - a.x, py = c.y - a.y;
      const double t = std::clamp((px * dx + py * dy) * inv_len2, 0.0, 1.0);
      const double rx = px - t * dx, ry = py - t * dy;
      if (rx * rx + ry * ry <= 1.0) edge.emplace_back(q.x, q.y);
    }
  }
  return edge;
}

// Share of directions around (cx, cy) holding an edge point. The outline of
// a digital disc has about 5.7 r points, so sectors of two points' width
// (at most 72) are all hit when the whole outline is visible.
double angular_coverage(const std::vector<cv::Point2d>& points, std::size_t outline_points, double cx, double cy) {
  const int sectors = static_cast<int>(std::clamp<std::size_t>(outline_points / 2, 8, 72));
  std::array<bool, 72> hit{};
  for (const auto& p : points) {
    const double a = std::atan2(p.y - cy, p.x - cx) + std::numbers::pi;
    const int s = std::min(sectors - 1, static_cast<int>(a / (2 * std::numbers::pi) * sectors));
    hit[static_cast<std::size_t>(s)] = true;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), true)) / sectors;
}

}  // namespace

bool FruitDetector::is_one_fruit(const cv::Mat1b& crop, cv::Point offset, cv::Size image) const {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(crop.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.size() != 1) return false;
  const auto& contour = contours.front();
  const double area = cv::countNonZero(crop);
  const double r_area = std::sqrt(area / std::numbers::pi);
  const auto edge = fruit_edge_points(contour, offset, image, 3.0 * std::sqrt(r_area) + 2.0);
  if (edge.size() < 8) return false;
  const auto c = fit_circle(edge);
  if (!c || c->r <= 0) return false;
  // A leaf across a fruit leaves pieces whose outer outline is one circle;
  // two touching fruit leave two arcs no single circle fits, and a region
  // larger than the fitted disc is more than one fruit.
  const double coverage = angular_coverage(edge, contour.size(), c->cx, c->cy);
  const double disc_area = std::numbers::pi * (c->r + 0.5) * (c->r + 0.5);
  return coverage >= 0.5 && c->rms <= std::max(0.75, 0.06 * c->r) && area <= 1.05 * disc_area;
}

FruitDetector::FruitDetector(const DetectorConfig& config, double fx, double fy) : config_(config), fx_(fx), fy_(fy) {
  if (config_.open_radius_px > 0) open_kernel_ = disc_kernel(config_.open_radius_px);
  if (config_.close_radius_px > 0) close_kernel_ = disc_kernel(config_.close_radius_px);
}

std::vector<std::pair<cv::Mat1b, cv::Point>> FruitDetector::split(const cv::Mat1b& crop, cv::Point offset) const {
  cv::Mat1f dist;
  cv::distanceTransform(crop, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  double max_dist = 0;
  cv::minMaxLoc(dist, nullptr, &max_dist);
  cv::Mat1f dilated;
  cv::dilate(dist, dilated, cv::Mat());
  const float floor_value =
      static_cast<float>(std::max(config_.split_min_radius_px, config_.split_min_peak_ratio * max_dist));

  struct Peak {
    float r;
    cv::Point p;
  };
  std::vector<Peak> peaks;
  for (int y = 0; y < dist.rows; ++y)
    for (int x = 0; x < dist.cols; ++x) {
      const float d = dist(y, x);
      if (d >= floor_value && d >= dilated(y, x)) peaks.push_back({d, {x, y}});
    }
  // Strongest first (raster order breaks ties, so the result is deterministic);
  // a peak inside the inscribed circle of a stronger one is the same fruit.
  std::stable_sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.r > b.r; });
  std::vector<Peak> centres;
  for (const Peak& p : peaks) {
    bool separate = true;
    for (const Peak& c : centres)
      if (std::hypot(p.p.x - c.p.x, p.p.y - c.p.y) <= c.r) separate = false;
    if (separate) centres.push_back(p);
  }
  if (centres.size() < 2) return {{crop, offset}};

  // Each pixel goes to the centre whose inscribed circle it is closest to.
  std::vector<std::pair<cv::Mat1b, cv::Point>> pieces;
  for (std::size_t k = 0; k < centres.size(); ++k) pieces.emplace_back(cv::Mat1b::zeros(crop.size()), offset);
  for (int y = 0; y < crop.rows; ++y)
    for (int x = 0; x < crop.cols; ++x) {
      if (!crop(y, x)) continue;
      std::size_t best = 0;
      double best_d = 1e18;
      for (std::size_t k = 0; k < centres.size(); ++k) {
        const double d = std::hypot(x - centres[k].p.x, y - centres[k].p.y) - centres[k].r;
        if (d < best_d) {
          best_d = d;
          best = k;
        }
      }
      pieces[best].first(y, x) = 255;
    }
  return pieces;
}

void FruitDetector::analyse(const cv::Mat1b& piece, cv::Point offset, cv::Size image, std::vector<Fruit>& out) const {
  const cv::Moments mo = cv::moments(piece, true);
  if (mo.m00 <= static_cast<double>(config_.min_area_px) || mo.m00 <= 0) return;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(piece.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  if (contours.empty()) return;
  const auto& contour = *std::max_element(contours.begin(), contours.end(),
                                          [](const auto& a, const auto& b) { return a.size() < b.size(); });

  Fruit f;
  f.area_px = mo.m00;
  f.u = mo.m10 / mo.m00 + offset.x;
  f.v = mo.m01 / mo.m00 + offset.y;
  f.diameter_px = 2.0 * std::sqrt(f.area_px / std::numbers::pi);
  const cv::Rect box = cv::boundingRect(contour);
  f.bbox = box + offset;
  f.diameter_x_px = box.width;
  f.diameter_y_px = box.height;
  const double perimeter = cv::arcLength(contour, true);
  f.roundness = perimeter > 0 ? std::min(1.0, 4 * std::numbers::pi * f.area_px / (perimeter * perimeter)) : 0.0;
  std::vector<cv::Point> hull;
  cv::convexHull(contour, hull);
  const double hull_area = cv::contourArea(hull);
  f.solidity = hull_area > 0 ? std::min(1.0, cv::contourArea(contour) / hull_area) : 1.0;

  // The flat runs of a digital circle's outline are about 2 sqrt(r) long;
  // a leaf's straight border across the fruit is far longer.
  const double max_hull_edge = 3.0 * std::sqrt(0.5 * f.diameter_px) + 2.0;
  const auto edge = fruit_edge_points(contour, offset, image, max_hull_edge);
  f.visible_fraction = angular_coverage(edge, contour.size(), f.u, f.v);
  if (config_.circle_fit && edge.size() >= 8) {
    if (const auto c = fit_circle(edge)) {
      const double coverage = angular_coverage(edge, contour.size(), c->cx, c->cy);
      // Outline points are pixel centres, half a pixel inside the true edge.
      if (coverage >= config_.min_visible_fraction && c->r < 2 * f.diameter_px) {
        f.u = c->cx;
        f.v = c->cy;
        f.diameter_px = 2 * (c->r + 0.5);
        f.visible_fraction = coverage;
        f.circle_fitted = true;
      }
    }
  }
  if (config_.reject_shapes) {
    const double aspect =
        static_cast<double>(std::max(box.width, box.height)) / std::max(1, std::min(box.width, box.height));
    // Fruit cut by a leaf are not round by area, so the fitted circle's
    // visible arc stands in for roundness when there is one.
    const bool round_enough = f.roundness >= config_.min_roundness || f.circle_fitted;
    if (!round_enough || f.solidity < config_.min_solidity || aspect > config_.max_aspect_ratio) return;
  }
  f.confidence =
      std::clamp(0.4 * std::min(1.0, f.roundness / 0.8) + 0.3 * f.solidity + 0.3 * f.visible_fraction, 0.0, 1.0);
  f.outline.reserve(contour.size());
  for (const cv::Point& p : contour) f.outline.push_back(p + offset);
  f.depth_m = depth_from_diameter(fx_, fy_, config_.fruit_diameter_m, f.diameter_px);
  f.cost = config_.kr * (image.width / (0.5 * f.diameter_px) - 1.0) + config_.kd_per_m * f.depth_m;
  out.push_back(std::move(f));
}

Detections FruitDetector::detect(const cv::Mat3b& bgr) {
  mask_.create(bgr.size());
  threshold_crcgcb(bgr.data, bgr.cols, bgr.rows, bgr.step, config_.thresholds, mask_.data, mask_.step);
  if (!open_kernel_.empty()) cv::morphologyEx(mask_, mask_, cv::MORPH_OPEN, open_kernel_);
  if (!close_kernel_.empty()) cv::morphologyEx(mask_, mask_, cv::MORPH_CLOSE, close_kernel_);

  Detections out;
  const auto& regions = labeler_.label(mask_, config_.min_area_px);
  for (std::size_t i = 0; i < regions.size(); ++i) {
    cv::Mat1b crop = labeler_.region_mask(i, 1);
    const cv::Point offset(regions[i].x0 - 1, regions[i].y0 - 1);
    if (config_.fill_holes) fill_holes(crop);
    // A region one circle explains is one fruit (possibly cut by a leaf):
    // splitting it at its distance-transform ridge would make fragments whose
    // small diameters put them far too deep.
    if (config_.split_touching && !(config_.circle_fit && is_one_fruit(crop, offset, bgr.size()))) {
      for (const auto& [piece, at] : split(crop, offset)) analyse(piece, at, bgr.size(), out.fruits);
    } else {
      analyse(crop, offset, bgr.size(), out.fruits);
    }
  }
  for (std::size_t i = 0; i < out.fruits.size(); ++i)
    if (out.selected < 0 || out.fruits[i].cost < out.fruits[static_cast<std::size_t>(out.selected)].cost)
      out.selected = static_cast<int>(i);
  if (out.selected >= 0) out.fruits[static_cast<std::size_t>(out.selected)].selected = true;
  return out;
}

}  // namespace harvest::vision
