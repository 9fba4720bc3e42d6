#include "vision/region_split.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "vision/bitmask.hpp"
#include "vision/circle_fit.hpp"
#include "vision/outline_circle.hpp"
#include "vision/segmentation.hpp"

namespace harvest::vision {

namespace {

// Fragment merging (merge_fragments), tuned on the simulated tree
// (tools: harvest-vision-eval): a fragment with an outer edge has at least
// this share of its edge points on the merged circle,
constexpr double kMergeMemberOnShare = 0.35;
// the merged circle's edge points cover at least this share of directions
// (each pair; a fruit behind leaves can come in several small pieces),
constexpr double kMergeMinCoverage = 0.2;
// and at most this share of the disc is open sky.
constexpr double kMergeMaxSkyShare = 0.03;  // Pixels of a mask (placed at `offset` in the image) outside the disc.
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

}  // namespace

// 64 pixels at a time as bits: their count and the sum of their x by
// popcounts (bit_index_sum), exact integers as before, without a branch per
// pixel to mispredict along the mask's edges.
// Holes are the background's 4-connected parts other than the one holding
// (0, 0) (the crop has a one-pixel empty frame, so that one is all outside):
// the background labelled by runs on its packed bits, and every run of the
// other parts painted in. Flooding from (0, 0) (cv::floodFill, 4-connected)
// and adding what it did not reach gave the same pixels and cost a copy of
// the crop, the fill and two passes over it.
void fill_holes(cv::Mat1b& crop) {
  if (crop.empty()) return;
  if (crop(0, 0) != 0) {  // no empty frame: flood what is connected to (0, 0), as before
    cv::Mat1b outside = crop.clone();
    cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(255));
    crop |= ~outside;
    return;
  }
  thread_local BitMask background;
  thread_local RegionLabeler labeler;
  background.create(crop.cols, crop.rows);
  for (int y = 0; y < crop.rows; ++y) {
    const uchar* row = crop.ptr<uchar>(y);
    uint64_t* bits = background.row(y);
    for (int x = 0; x < crop.cols; x += 64) {
      const int n = std::min(64, crop.cols - x);
      bits[x / 64] = ~pack_bytes(row + x, n) & (n == 64 ? ~uint64_t{0} : (uint64_t{1} << n) - 1);
    }
  }
  labeler.label(background, 0);  // region 0 starts at (0, 0): the outside
  for (const Run& r : labeler.runs())
    if (r.label > 0) std::memset(crop.ptr<uchar>(r.y) + r.x0, 255, static_cast<std::size_t>(r.x1 - r.x0));
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("popcnt", "default")))  // the popcounts in one instruction where the CPU has it
#endif
MaskMoments
mask_moments(const cv::Mat1b& mask) {
  int64_t m00 = 0, m10 = 0, m01 = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uchar* row = mask.ptr<uchar>(y);
    int64_t count = 0, sum_x = 0;
    for (int x = 0; x < mask.cols; x += 64) {
      const uint64_t bits = pack_bytes(row + x, std::min(64, mask.cols - x));
      const int64_t n = std::popcount(bits);
      count += n, sum_x += n * x + bit_index_sum(bits);
    }
    m00 += count, m10 += sum_x, m01 += count * y;
  }
  return {static_cast<double>(m00), static_cast<double>(m10), static_cast<double>(m01)};
}

Piece RegionSplitter::make_piece(cv::Mat1b mask, cv::Point offset, cv::Size image, const cv::Mat1b* region,
                                 Outline* known) const {
  Piece p;
  p.offset = offset;
  std::vector<std::vector<cv::Point>> contours;
  if (known && known->traced)
    contours = std::move(known->contours);
  else
    cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  p.mask = std::move(mask);
  if (contours.empty()) return p;
  p.contour = *std::max_element(contours.begin(), contours.end(),
                                [](const auto& a, const auto& b) { return a.size() < b.size(); });
  p.outline_points = p.contour.size();
  if (config_.merge_fragments || config_.peel_to_circle)
    for (const auto& c : contours)
      for (const cv::Point& q : c) p.outer.emplace_back(q.x + offset.x, q.y + offset.y);
  p.moments = mask_moments(p.mask);
  p.area = p.moments.m00;
  for (const auto& c : contours) p.box |= cv::boundingRect(c);
  p.box += offset;
  // The flat runs of a digital circle's outline are about 2 sqrt(r) long;
  // a leaf's straight border across the fruit is far longer.
  const double diameter = 2.0 * std::sqrt(p.area / std::numbers::pi);
  if (known && known->has_edge && contours.size() == 1)
    p.edge = std::move(known->edge);  // the same contour, the same maximum edge length
  else
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
void RegionSplitter::peel(Piece piece, cv::Size image, std::vector<Piece>& out) const {
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
  // Each part outside on a mask of its own size (with the empty frame), in
  // raster order of their first pixels. The detector's own run labeller:
  // cv::connectedComponentsWithStats gives the same parts but costs a label
  // image the size of the piece (a close fruit: 50,000 pixels, a tenth of a
  // hand frame's detection).
  RegionLabeler labeler;
  const auto& parts = labeler.label(rest, 0);
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const cv::Rect box(parts[k].x0, parts[k].y0, parts[k].x1 - parts[k].x0, parts[k].y1 - parts[k].y0);
    cv::Mat1b part = labeler.region_mask(k, 1);
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
void RegionSplitter::merge_fragments(std::vector<Piece>& pieces, const cv::Mat3b& bgr) const {
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
    // Both pieces' points in buffers kept across pairs (no allocation per pair).
    thread_local std::vector<cv::Point2d> edge, outer;
    edge.clear();
    outer.clear();
    edge.insert(edge.end(), a.edge.begin(), a.edge.end());
    edge.insert(edge.end(), b.edge.begin(), b.edge.end());
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
    cv::findContours(m.mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    m.contour = *std::max_element(contours.begin(), contours.end(),
                                  [](const auto& x, const auto& y) { return x.size() < y.size(); });
    m.edge = a.edge;
    m.edge.insert(m.edge.end(), b.edge.begin(), b.edge.end());
    m.outer = a.outer;
    m.outer.insert(m.outer.end(), b.outer.begin(), b.outer.end());
    m.outline_points = a.outline_points + b.outline_points;
    m.moments = mask_moments(m.mask);
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
bool RegionSplitter::is_one_fruit(const cv::Mat1b& crop, cv::Point offset, cv::Size image, Outline& outline) const {
  auto& contours = outline.contours;
  cv::findContours(crop, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  outline.traced = true;
  if (contours.size() != 1) return false;
  const auto& contour = contours.front();
  const double area = cv::countNonZero(crop);
  const double r_area = std::sqrt(area / std::numbers::pi);
  outline.edge = fruit_edge_points(contour, offset, image, 3.0 * std::sqrt(r_area) + 2.0);
  outline.has_edge = true;
  const auto& edge = outline.edge;
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
std::vector<std::pair<cv::Mat1b, cv::Point>> RegionSplitter::split(const cv::Mat1b& crop, cv::Point offset) const {
  cv::Mat1f dist;
  cv::distanceTransform(crop, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  double max_dist = 0;
  cv::minMaxLoc(dist, nullptr, &max_dist);
  const float floor_value =
      static_cast<float>(std::max(config_.split_min_radius_px, config_.split_min_peak_ratio * max_dist));

  struct Peak {
    float r;
    cv::Point p;
  };
  // Local maxima (at least each of the 8 neighbours inside the crop) above
  // the floor. Checked only where the floor is met: a 3x3 dilation of the
  // whole map did the same and cost more than the distance transform.
  std::vector<Peak> peaks;
  for (int y = 0; y < dist.rows; ++y) {
    const float* row = dist.ptr<float>(y);
    for (int x = 0; x < dist.cols; ++x) {
      const float d = row[x];
      if (d < floor_value) continue;
      bool peak = true;
      for (int ny = std::max(0, y - 1); peak && ny <= std::min(dist.rows - 1, y + 1); ++ny) {
        const float* n = dist.ptr<float>(ny);
        for (int nx = std::max(0, x - 1); nx <= std::min(dist.cols - 1, x + 1); ++nx)
          if (n[nx] > d) {
            peak = false;
            break;
          }
      }
      if (peak) peaks.push_back({d, {x, y}});
    }
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
void RegionSplitter::add_region(cv::Mat1b crop, cv::Point offset, cv::Size image, std::vector<Piece>& out) const {
  if (config_.fill_holes) fill_holes(crop);
  // A region one circle explains is one fruit (possibly cut by a leaf):
  // splitting it at its distance-transform ridge would make fragments whose
  // small diameters put them far too deep.
  // The crop's contours (and edge points) from is_one_fruit serve make_piece
  // when the crop goes on whole.
  Outline outline;
  if (config_.split_touching && !(config_.circle_fit && is_one_fruit(crop, offset, image, outline))) {
    auto parts = split(crop, offset);
    if (parts.size() == 1) {
      peel(make_piece(std::move(parts.front().first), offset, image, nullptr, &outline), image, out);
      return;
    }
    for (auto& [part, at] : parts) peel(make_piece(std::move(part), at, image, &crop), image, out);
  } else {
    peel(make_piece(std::move(crop), offset, image, nullptr, &outline), image, out);
  }
}

}  // namespace harvest::vision
