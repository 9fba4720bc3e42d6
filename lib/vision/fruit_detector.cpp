#include "vision/fruit_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>

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
  c.peel_to_circle = true;
  c.merge_fragments = true;
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
  c.peel_to_circle = n.get("peel_to_circle", c.peel_to_circle);
  c.merge_fragments = n.get("merge_fragments", c.merge_fragments);
  c.merge_max_gap_ratio = n.get("merge_max_gap_ratio", c.merge_max_gap_ratio, {0.0, 10.0});
  c.sky_cb_min = n.get("sky_cb_min", c.sky_cb_min, {-1000.0, 1000.0});
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

// Fragment merging (merge_fragments), tuned on the simulated tree
// (tools: harvest-vision-eval): a fragment with an outer edge has at least
// this share of its edge points on the merged circle,
constexpr double kMergeMemberOnShare = 0.35;
// the merged circle's edge points cover at least this share of directions
// (each pair; a fruit behind leaves can come in several small pieces),
constexpr double kMergeMinCoverage = 0.2;
// and at most this share of the disc is open sky.
constexpr double kMergeMaxSkyShare = 0.03;
// Circle candidates tried per fit (fit_outline_circle).
constexpr int kCircleCandidates = 48;

// Points farther than this from a circle are not on it.
double circle_tolerance(double r) { return std::max(1.5, 0.06 * r); }

// |d - r| <= tol on squared distances (no square root: this runs for every
// candidate circle).
struct OnCircle {
  explicit OnCircle(const Circle& c) : c(c) {
    const double tol = circle_tolerance(c.r), lo = std::max(0.0, c.r - tol);
    lo2 = lo * lo;
    hi2 = (c.r + tol) * (c.r + tol);
  }
  bool operator()(const cv::Point2d& p) const {
    const double dx = p.x - c.cx, dy = p.y - c.cy, d2 = dx * dx + dy * dy;
    return d2 >= lo2 && d2 <= hi2;
  }
  Circle c;
  double lo2, hi2;
};

std::size_t points_on_circle(const std::vector<cv::Point2d>& points, const Circle& c) {
  return static_cast<std::size_t>(std::count_if(points.begin(), points.end(), OnCircle(c)));
}

std::vector<cv::Point2d> on_circle(const std::vector<cv::Point2d>& points, const Circle& c) {
  std::vector<cv::Point2d> on;
  std::copy_if(points.begin(), points.end(), std::back_inserter(on), OnCircle(c));
  return on;
}

// Angular share of the circle its on-circle points cover.
double circle_coverage(const std::vector<cv::Point2d>& points, const Circle& c) {
  return angular_coverage(on_circle(points, c), static_cast<std::size_t>(5.7 * c.r), c.cx, c.cy);
}

// Pixels of a mask (placed at `offset` in the image) outside the disc.
int pixels_outside(const cv::Mat1b& mask, cv::Point offset, const Circle& c, double margin) {
  // Row by row, only the stretches left and right of the disc's chord.
  const double r = c.r + margin;
  int outside = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uchar* row = mask.ptr<uchar>(y);
    const double dy = y + offset.y - c.cy;
    int x0 = mask.cols, x1 = -1;  // inside: x0..x1
    if (std::fabs(dy) <= r) {
      const double half = std::sqrt(r * r - dy * dy);
      x0 = std::max(0, static_cast<int>(std::ceil(c.cx - half - offset.x)));
      x1 = std::min(mask.cols - 1, static_cast<int>(std::floor(c.cx + half - offset.x)));
    }
    if (x0 > x1) x0 = mask.cols, x1 = mask.cols - 1;
    for (int x = 0; x < std::min(x0, mask.cols); ++x) outside += row[x] != 0;
    for (int x = x1 + 1; x < mask.cols; ++x) outside += row[x] != 0;
  }
  return outside;
}

// Share of the pixels well inside the disc that are open sky (Cb, eq. 2-1,
// above cb_min): a fruit's disc shows fruit or what is in front of it, never
// the sky behind it. In exact integers like the threshold (1000 Cb).
double sky_share(const cv::Mat3b& bgr, const Circle& c, double cb_min) {
  const double r = c.r - 1.5;
  if (r <= 0) return 0.0;
  const int step = std::max(1, static_cast<int>(r / 12));  // about 450 samples at most
  const int y0 = std::max(0, static_cast<int>(std::ceil(c.cy - r))),
            y1 = std::min(bgr.rows - 1, static_cast<int>(c.cy + r));
  const int x0 = std::max(0, static_cast<int>(std::ceil(c.cx - r))),
            x1 = std::min(bgr.cols - 1, static_cast<int>(c.cx + r));
  const long limit = std::lround(cb_min * 1000.0);
  long inside = 0, sky = 0;
  for (int y = y0; y <= y1; y += step) {
    const cv::Vec3b* row = bgr.ptr<cv::Vec3b>(y);
    const double dy = y - c.cy;
    for (int x = x0; x <= x1; x += step) {
      const double dx = x - c.cx;
      if (dx * dx + dy * dy > r * r) continue;
      ++inside;
      const cv::Vec3b& p = row[x];
      sky += -299L * p[2] - 587L * p[1] + 886L * p[0] > limit;
    }
  }
  return inside > 0 ? static_cast<double>(sky) / static_cast<double>(inside) : 0.0;
}

struct OutlineFit {
  Circle circle;
  std::size_t on = 0;  // edge points on the circle
};

// The circle with radius in [r_min, r_max] that the most edge points lie on
// and that no more than 3 % of the outline points (if any are given) lie
// outside. Stretches of leaf edge that pass the hull test lie inside a
// fruit's disc, so they cannot pull it the way they pull a least-squares
// fit. Candidates are circles through point triples (a fixed pseudo-random
// sequence, so the result is deterministic); the best is refitted on the
// points on it.
std::optional<OutlineFit> fit_outline_circle(const std::vector<cv::Point2d>& edge,
                                             const std::vector<cv::Point2d>& outline, double r_min, double r_max) {
  const std::size_t n = edge.size();
  if (n < 8) return std::nullopt;
  // Candidates are scored on at most about 160 points of each set (a large
  // fruit near the camera has thousands of outline points).
  const auto thin = [](const std::vector<cv::Point2d>& points) {
    const std::size_t stride = points.size() / 160 + 1;
    std::vector<cv::Point2d> out;
    for (std::size_t i = 0; i < points.size(); i += stride) out.push_back(points[i]);
    return out;
  };
  const std::vector<cv::Point2d> scored = n > 160 ? thin(edge) : edge;
  const std::vector<cv::Point2d> held = outline.size() > 160 ? thin(outline) : outline;
  const std::size_t min_on = std::max<std::size_t>(3, 8 * scored.size() / n);
  const std::size_t allowed_out = held.size() * 3 / 100 + 1;
  const auto on_count = [&](const Circle& c, const std::vector<cv::Point2d>& points) {
    return c.r >= r_min && c.r <= r_max ? points_on_circle(points, c) : std::size_t{0};
  };
  const auto contains = [&](const Circle& c) {
    const double r2 = (c.r + 1.5) * (c.r + 1.5);
    std::size_t out = 0;
    for (const auto& p : held)
      if ((p.x - c.cx) * (p.x - c.cx) + (p.y - c.cy) * (p.y - c.cy) > r2 && ++out > allowed_out) return false;
    return true;
  };
  std::optional<OutlineFit> best;  // .on counts the scored points until the refit
  const auto consider = [&](const Circle& c) {
    const std::size_t on = on_count(c, scored);
    if (on < min_on || (best && on <= best->on) || !contains(c)) return;
    best = OutlineFit{c, on};
  };
  uint32_t state = 0x9e3779b9u ^ static_cast<uint32_t>(n);
  const auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return static_cast<std::size_t>(state >> 8) % n;
  };
  for (int k = 0; k < kCircleCandidates; ++k) {
    const cv::Point2d a = edge[next()], b = edge[next()], c = edge[next()];
    // Circumcircle of a, b, c.
    const double bx = b.x - a.x, by = b.y - a.y, cx = c.x - a.x, cy = c.y - a.y;
    const double d = 2 * (bx * cy - by * cx);
    if (std::fabs(d) < 1e-9) continue;
    const double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
    const double ux = (cy * b2 - by * c2) / d, uy = (bx * c2 - cx * b2) / d;
    consider(Circle{a.x + ux, a.y + uy, std::sqrt(ux * ux + uy * uy), 0});
    if (best && best->on >= scored.size() * 9 / 10) break;  // it could hardly get better
  }
  if (!best) return best;
  best->on = on_count(best->circle, edge);
  auto on = on_circle(edge, best->circle);
  if (on.size() > 320) on = thin(on);  // 160 points are plenty for the refit
  if (const auto refit = fit_circle(on); refit && on_count(*refit, edge) >= best->on && contains(*refit)) {
    best = OutlineFit{*refit, on_count(*refit, edge)};
  } else {
    double ss = 0;
    for (const auto& p : on) {
      const double dx = p.x - best->circle.cx, dy = p.y - best->circle.cy;
      const double res = std::sqrt(dx * dx + dy * dy) - best->circle.r;
      ss += res * res;
    }
    best->circle.rms = std::sqrt(ss / static_cast<double>(on.size()));
  }
  return best;
}

}  // namespace

// A piece of the mask that may be one fruit: a region, a part of a split
// region, or fragments merged because they lie on one circle.
struct FruitDetector::Piece {
  cv::Mat1b mask;                  // with an empty frame of at least one pixel
  cv::Point offset;                // image position of mask(0, 0)
  std::vector<cv::Point> contour;  // largest outer outline, mask coordinates
  std::vector<cv::Point2d> edge;   // fruit-edge points, image coordinates
  std::vector<cv::Point2d> outer;  // every outer outline point, image coordinates
  std::size_t outline_points = 0;  // outer outline length of all fragments
  cv::Moments moments;             // of the mask (binary)
  double area = 0;
  cv::Rect box;  // image coordinates
  int fragments = 1;
};

FruitDetector::Piece FruitDetector::make_piece(cv::Mat1b mask, cv::Point offset, cv::Size image,
                                               const cv::Mat1b* region) const {
  Piece p;
  p.offset = offset;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  p.mask = std::move(mask);
  if (contours.empty()) return p;
  p.contour = *std::max_element(contours.begin(), contours.end(),
                                [](const auto& a, const auto& b) { return a.size() < b.size(); });
  p.outline_points = p.contour.size();
  if (config_.merge_fragments || config_.peel_to_circle)
    for (const auto& c : contours)
      for (const cv::Point& q : c) p.outer.emplace_back(q.x + offset.x, q.y + offset.y);
  p.moments = cv::moments(p.mask, true);
  p.area = p.moments.m00;
  for (const auto& c : contours) p.box |= cv::boundingRect(c);
  p.box += offset;
  // The flat runs of a digital circle's outline are about 2 sqrt(r) long;
  // a leaf's straight border across the fruit is far longer.
  const double diameter = 2.0 * std::sqrt(p.area / std::numbers::pi);
  p.edge = fruit_edge_points(p.contour, offset, image, 3.0 * std::sqrt(0.5 * diameter) + 2.0);
  if (region) {
    // A cut made by the splitter runs through the region, not along its edge.
    const cv::Mat1b& r = *region;
    std::erase_if(p.edge, [&](const cv::Point2d& q) {
      const int x = static_cast<int>(q.x) - offset.x, y = static_cast<int>(q.y) - offset.y;
      return r(y - 1, x) && r(y + 1, x) && r(y, x - 1) && r(y, x + 1);
    });
  }
  return p;
}

// A fruit joined to slivers of others (a crescent of a fruit behind it, a
// bit of one peeking past its edge) that the splitter leaves attached: the
// circle most of the outline supports is the fruit; what lies outside it
// goes on as separate pieces. Otherwise the hull, and so the fitted circle,
// takes in the slivers' tips and the fruit comes out too large.
void FruitDetector::peel(Piece piece, cv::Size image, std::vector<Piece>& out) const {
  if (!config_.peel_to_circle || !config_.circle_fit || piece.outer.size() < 8) {
    out.push_back(std::move(piece));
    return;
  }
  const double extent = std::max(piece.box.width, piece.box.height);
  // The whole outline, not the hull's edge points: the slivers' tips make
  // the hull, and the fruit's own arc between them lies inside it.
  const auto fit = fit_outline_circle(piece.outer, {}, 0.2 * extent, extent);
  if (!fit || fit->circle.rms > std::max(0.75, 0.06 * fit->circle.r)) {
    out.push_back(std::move(piece));
    return;
  }
  const Circle& c = fit->circle;
  const int outside = pixels_outside(piece.mask, piece.offset, c, 1.5);
  // Only a convincing fruit (half its outline seen, its disc mostly filled:
  // a concave leaf bite also fits a circle) with something outside it.
  if (circle_coverage(piece.outer, c) < 0.5 || piece.area - outside < 0.6 * std::numbers::pi * c.r * c.r ||
      outside <= std::max(3.0, 0.05 * piece.area)) {
    out.push_back(std::move(piece));
    return;
  }
  cv::Mat1b inside = cv::Mat1b::zeros(piece.mask.size()), rest = cv::Mat1b::zeros(piece.mask.size());
  const double r2 = (c.r + 1.5) * (c.r + 1.5);
  for (int y = 0; y < piece.mask.rows; ++y)
    for (int x = 0; x < piece.mask.cols; ++x) {
      if (!piece.mask(y, x)) continue;
      const double dx = x + piece.offset.x - c.cx, dy = y + piece.offset.y - c.cy;
      (dx * dx + dy * dy <= r2 ? inside : rest)(y, x) = 255;
    }
  out.push_back(make_piece(inside, piece.offset, image, &piece.mask));
  // Each part outside on a mask of its own size (with the empty frame).
  cv::Mat1i labels, stats;
  cv::Mat centroids;
  const int n = cv::connectedComponentsWithStats(rest, labels, stats, centroids, 4);
  for (int k = 1; k < n; ++k) {
    const cv::Rect box(stats(k, cv::CC_STAT_LEFT), stats(k, cv::CC_STAT_TOP), stats(k, cv::CC_STAT_WIDTH),
                       stats(k, cv::CC_STAT_HEIGHT));
    cv::Mat1b part = cv::Mat1b::zeros(box.height + 2, box.width + 2);
    part(cv::Rect(1, 1, box.width, box.height)).setTo(255, labels(box) == k);
    cv::Mat1b region = cv::Mat1b::zeros(part.size());
    const cv::Rect from = cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2) &
                          cv::Rect(0, 0, piece.mask.cols, piece.mask.rows);
    piece.mask(from).copyTo(region(from - cv::Point(box.x - 1, box.y - 1)));
    const cv::Point at = piece.offset + cv::Point(box.x - 1, box.y - 1);
    out.push_back(make_piece(part, at, image, &region));
  }
}

// Fragments of one fruit (cut apart by a leaf, or by the splitter along a
// crescent's ridge) each show a stretch of the same outline: their edge
// points fit one circle, every fragment with an outer edge contributes to
// it, and none sticks out of the disc. Two fruit fail (their arcs fit no
// single circle, or one sticks out of the other's disc). Greedy, best fit
// first; pair results are kept until one of the pair changes.
void FruitDetector::merge_fragments(std::vector<Piece>& pieces, const cv::Mat3b& bgr) const {
  std::erase_if(pieces, [](const Piece& p) { return p.area <= 0; });
  const auto size_of = [](const Piece& p) { return 2.0 * std::sqrt(p.area / std::numbers::pi); };
  const auto near = [&](const Piece& a, const Piece& b) {
    const int gx = std::max({0, a.box.x - b.box.br().x, b.box.x - a.box.br().x});
    const int gy = std::max({0, a.box.y - b.box.br().y, b.box.y - a.box.br().y});
    return std::hypot(gx, gy) <= std::max(2.0, config_.merge_max_gap_ratio * std::max(size_of(a), size_of(b)));
  };
  // Score of merging a and b (lower is better), negative if they are not one fruit.
  const auto score = [&](const Piece& a, const Piece& b) -> double {
    constexpr double kNo = -1;
    if (!near(a, b) || a.edge.size() + b.edge.size() < 8) return kNo;
    std::vector<cv::Point2d> edge, outer;
    edge.reserve(a.edge.size() + b.edge.size());
    edge.insert(edge.end(), a.edge.begin(), a.edge.end());
    edge.insert(edge.end(), b.edge.begin(), b.edge.end());
    outer.reserve(a.outer.size() + b.outer.size());
    outer.insert(outer.end(), a.outer.begin(), a.outer.end());
    outer.insert(outer.end(), b.outer.begin(), b.outer.end());
    // The fruit holds both pieces, and they show at least a radius of it.
    const cv::Rect box = a.box | b.box;
    const double extent = std::max(box.width, box.height);
    const auto fit = fit_outline_circle(edge, outer, 0.5 * extent - 1.0, extent);
    if (!fit) return kNo;
    const Circle& c = fit->circle;
    if (c.rms > std::max(0.75, 0.06 * c.r)) return kNo;
    for (const Piece* p : {&a, &b})
      if (p->edge.size() >= 5 && points_on_circle(p->edge, c) < kMergeMemberOnShare * p->edge.size()) return kNo;
    if (circle_coverage(edge, c) < kMergeMinCoverage) return kNo;
    for (const Piece* p : {&a, &b})
      if (pixels_outside(p->mask, p->offset, c, 1.5) > 0.03 * p->area + 2) return kNo;
    // Two fruit with sky between them fit one circle that takes in the sky.
    if (sky_share(bgr, c, config_.sky_cb_min) > kMergeMaxSkyShare) return kNo;
    return c.rms / c.r;
  };

  const std::size_t n = pieces.size();
  std::vector<double> scores(n * n, -1.0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) scores[i * n + j] = score(pieces[i], pieces[j]);
  std::vector<bool> alive(n, true);
  for (;;) {
    std::size_t bi = 0, bj = 0;
    double best = -1;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j) {
        const double s = scores[i * n + j];
        if (alive[i] && alive[j] && s >= 0 && (best < 0 || s < best)) best = s, bi = i, bj = j;
      }
    if (best < 0) break;
    Piece& a = pieces[bi];
    Piece& b = pieces[bj];
    Piece m;
    m.box = a.box | b.box;
    m.offset = m.box.tl() - cv::Point(1, 1);
    m.mask = cv::Mat1b::zeros(m.box.height + 2, m.box.width + 2);
    for (const Piece* p : {&a, &b}) {
      const cv::Rect from = p->box - p->offset, to = p->box - m.offset;
      m.mask(to) |= p->mask(from);
    }
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m.mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    m.contour = *std::max_element(contours.begin(), contours.end(),
                                  [](const auto& x, const auto& y) { return x.size() < y.size(); });
    m.edge = a.edge;
    m.edge.insert(m.edge.end(), b.edge.begin(), b.edge.end());
    m.outer = a.outer;
    m.outer.insert(m.outer.end(), b.outer.begin(), b.outer.end());
    m.outline_points = a.outline_points + b.outline_points;
    m.moments = cv::moments(m.mask, true);
    m.area = a.area + b.area;
    m.fragments = a.fragments + b.fragments;
    a = std::move(m);
    alive[bj] = false;
    for (std::size_t k = 0; k < n; ++k) {
      if (k == bi || !alive[k]) continue;
      const std::size_t lo = std::min(k, bi), hi = std::max(k, bi);
      scores[lo * n + hi] = score(pieces[lo], pieces[hi]);
    }
  }
  std::vector<Piece> kept;
  for (std::size_t i = 0; i < n; ++i)
    if (alive[i]) kept.push_back(std::move(pieces[i]));
  pieces = std::move(kept);
}

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
        const double dx = x - centres[k].p.x, dy = y - centres[k].p.y;
        const double d = std::sqrt(dx * dx + dy * dy) - centres[k].r;
        if (d < best_d) {
          best_d = d;
          best = k;
        }
      }
      pieces[best].first(y, x) = 255;
    }
  return pieces;
}

void FruitDetector::analyse(const Piece& piece, cv::Size image, std::vector<Fruit>& out) const {
  if (piece.area <= static_cast<double>(config_.min_area_px) || piece.area <= 0 || piece.contour.empty()) return;
  const cv::Moments& mo = piece.moments;
  const auto& contour = piece.contour;
  const cv::Point offset = piece.offset;
  const bool merged = piece.fragments > 1;

  Fruit f;
  f.area_px = mo.m00;
  f.u = mo.m10 / mo.m00 + offset.x;
  f.v = mo.m01 / mo.m00 + offset.y;
  f.diameter_px = 2.0 * std::sqrt(f.area_px / std::numbers::pi);
  const cv::Rect box = merged ? piece.box - offset : cv::boundingRect(contour);
  f.bbox = box + offset;
  f.diameter_x_px = box.width;
  f.diameter_y_px = box.height;
  const double perimeter = cv::arcLength(contour, true);
  f.roundness = perimeter > 0 ? std::min(1.0, 4 * std::numbers::pi * f.area_px / (perimeter * perimeter)) : 0.0;
  std::vector<cv::Point> hull;
  cv::convexHull(contour, hull);
  const double hull_area = cv::contourArea(hull);
  f.solidity = hull_area > 0 ? std::min(1.0, cv::contourArea(contour) / hull_area) : 1.0;

  const auto& edge = piece.edge;
  f.visible_fraction = angular_coverage(edge, piece.outline_points, f.u, f.v);
  if (config_.circle_fit && edge.size() >= 8) {
    std::optional<Circle> c;
    if (merged) {
      const double extent = std::max(box.width, box.height);
      if (const auto fit = fit_outline_circle(edge, piece.outer, 0.5 * extent - 1.0, extent)) c = fit->circle;
    } else {
      c = fit_circle(edge);
    }
    if (c) {
      const double coverage = angular_coverage(edge, piece.outline_points, c->cx, c->cy);
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
  if (config_.reject_shapes && !(merged && f.circle_fitted)) {
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
  // Merging needs every piece first; otherwise each region is done at once.
  const bool merging = config_.merge_fragments && config_.circle_fit;
  std::vector<Piece> pieces;
  for (std::size_t i = 0; i < regions.size(); ++i) {
    cv::Mat1b crop = labeler_.region_mask(i, 1);
    const cv::Point offset(regions[i].x0 - 1, regions[i].y0 - 1);
    if (config_.fill_holes) fill_holes(crop);
    // A region one circle explains is one fruit (possibly cut by a leaf):
    // splitting it at its distance-transform ridge would make fragments whose
    // small diameters put them far too deep.
    if (config_.split_touching && !(config_.circle_fit && is_one_fruit(crop, offset, bgr.size()))) {
      auto parts = split(crop, offset);
      const cv::Mat1b* region = parts.size() > 1 ? &crop : nullptr;
      for (auto& [part, at] : parts) peel(make_piece(std::move(part), at, bgr.size(), region), bgr.size(), pieces);
    } else {
      peel(make_piece(std::move(crop), offset, bgr.size(), nullptr), bgr.size(), pieces);
    }
    if (!merging) {
      for (const Piece& p : pieces) analyse(p, bgr.size(), out.fruits);
      pieces.clear();
    }
  }
  if (merging) {
    merge_fragments(pieces, bgr);
    for (const Piece& p : pieces) analyse(p, bgr.size(), out.fruits);
  }
  for (std::size_t i = 0; i < out.fruits.size(); ++i)
    if (out.selected < 0 || out.fruits[i].cost < out.fruits[static_cast<std::size_t>(out.selected)].cost)
      out.selected = static_cast<int>(i);
  if (out.selected >= 0) out.fruits[static_cast<std::size_t>(out.selected)].selected = true;
  return out;
}

}  // namespace harvest::vision
