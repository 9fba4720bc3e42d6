#include "vision/outline_circle.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>

namespace harvest::vision {

namespace {

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

}  // namespace

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

double convex_hull_area(const std::vector<cv::Point>& points) {
  if (points.size() < 3) return 0.0;
  int x0 = points[0].x, x1 = points[0].x;
  for (const cv::Point& p : points) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
  // Per column its lowest and highest y (columns without points: lo > hi).
  thread_local std::vector<int> lo, hi;
  const auto columns = static_cast<std::size_t>(x1 - x0 + 1);
  lo.assign(columns, std::numeric_limits<int>::max());
  hi.assign(columns, std::numeric_limits<int>::min());
  for (const cv::Point& p : points) {
    const auto c = static_cast<std::size_t>(p.x - x0);
    lo[c] = std::min(lo[c], p.y);
    hi[c] = std::max(hi[c], p.y);
  }
  // Andrew's monotone chain over the candidates in (x, y) order.
  thread_local std::vector<cv::Point> chain;
  chain.clear();
  const auto cross = [](cv::Point o, cv::Point a, cv::Point b) {
    return static_cast<int64_t>(a.x - o.x) * (b.y - o.y) - static_cast<int64_t>(a.y - o.y) * (b.x - o.x);
  };
  const auto push = [&](cv::Point p, std::size_t floor) {
    while (chain.size() >= floor + 2 && cross(chain[chain.size() - 2], chain.back(), p) <= 0) chain.pop_back();
    chain.push_back(p);
  };
  for (std::size_t c = 0; c < columns; ++c) {  // lower hull, left to right
    if (lo[c] > hi[c]) continue;
    const int x = x0 + static_cast<int>(c);
    push({x, lo[c]}, 0);
    if (hi[c] != lo[c]) push({x, hi[c]}, 0);
  }
  const std::size_t lower = chain.size() - 1;
  for (std::size_t c = columns; c-- > 0;) {  // upper hull, right to left
    if (lo[c] > hi[c]) continue;
    const int x = x0 + static_cast<int>(c);
    if (hi[c] != lo[c]) push({x, hi[c]}, lower);
    push({x, lo[c]}, lower);
  }
  int64_t twice = 0;  // the shoelace sum, exact
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    twice += static_cast<int64_t>(chain[i].x) * chain[i + 1].y - static_cast<int64_t>(chain[i + 1].x) * chain[i].y;
  return 0.5 * std::fabs(static_cast<double>(twice));
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
  const auto thin_into = [](const std::vector<cv::Point2d>& points, std::vector<cv::Point2d>& out) {
    const std::size_t stride = points.size() / 160 + 1;
    out.clear();
    for (std::size_t i = 0; i < points.size(); i += stride) out.push_back(points[i]);
  };
  const auto thin = [&](const std::vector<cv::Point2d>& points) {
    std::vector<cv::Point2d> out;
    thin_into(points, out);
    return out;
  };
  // The sets themselves when they are small enough, not copies of them.
  thread_local std::vector<cv::Point2d> thinned_edge, thinned_outline;
  if (n > 160) thin_into(edge, thinned_edge);
  if (outline.size() > 160) thin_into(outline, thinned_outline);
  const std::vector<cv::Point2d>& scored = n > 160 ? thinned_edge : edge;
  const std::vector<cv::Point2d>& held = outline.size() > 160 ? thinned_outline : outline;
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
  // A candidate needs more scored points on it than the best so far: the
  // count stops as soon as the points left cannot get it there (the same
  // choice as counting them all).
  const auto consider = [&](const Circle& c) {
    if (!(c.r >= r_min && c.r <= r_max)) return;  // counts no points: below min_on
    const std::size_t needed = std::max(min_on, best ? best->on + 1 : std::size_t{0});
    const OnCircle is_on(c);
    std::size_t on = 0;
    for (std::size_t i = 0; i < scored.size(); ++i) {
      if (on + (scored.size() - i) < needed) return;
      on += is_on(scored[i]);
    }
    if (on < needed || !contains(c)) return;
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

}  // namespace harvest::vision
