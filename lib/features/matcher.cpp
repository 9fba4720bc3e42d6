#include "features/matcher.hpp"

#include <algorithm>
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <opencv2/imgproc.hpp>

#include "features/corners.hpp"
#include "features/simd.hpp"
#include "geometry/homography.hpp"

namespace harvest::features {

namespace geo = harvest::geometry;
using detail::Nearest;

const char* to_string(MatchStatus s) {
  switch (s) {
    case MatchStatus::kOk:
      return "ok";
    case MatchStatus::kTooFew:
      return "too few consistent matches";
    case MatchStatus::kNoDesired:
      return "no desired image";
    case MatchStatus::kDegenerate:
      return "degenerate matches";
  }
  return "?";
}

namespace {

cv::Mat1b region_mask(const cv::Size& size, const cv::Rect& region) {
  if (region.area() <= 0) return {};
  cv::Mat1b m(size, uint8_t(0));
  m(region & cv::Rect(0, 0, size.width, size.height)).setTo(255);
  return m;
}

geo::Points2 to_eigen(const std::vector<cv::Point2f>& p) {
  geo::Points2 out;
  out.reserve(p.size());
  for (const auto& q : p) out.emplace_back(q.x, q.y);
  return out;
}

cv::Point2f apply(const cv::Matx33d& G, const cv::Point2f& p) {
  const cv::Vec3d q = G * cv::Vec3d(p.x, p.y, 1.0);
  return {static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2])};
}

cv::Matx33d to_cv(const Eigen::Matrix3d& G) {
  cv::Matx33d M;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) M(r, c) = G(r, c);
  return M;
}

// The selection every Hamming build shares: per desired row the best and second-best distance (ties keep the
// lower index), per current row the best desired row. Plain inline code: it inlines into each build's loop.
struct NearestSelection {
  NearestSelection(int nd, int nc, Nearest& out) : out_(out), back_dist_(static_cast<std::size_t>(nc), 1 << 20) {
    out.best.assign(static_cast<std::size_t>(nd), -1);
    out.best_dist.assign(static_cast<std::size_t>(nd), 1 << 20);
    out.second_dist.assign(static_cast<std::size_t>(nd), 1 << 20);
    out.back.assign(static_cast<std::size_t>(nc), -1);
  }
  HARVEST_SIMD_INLINE void begin_row() { b1_ = b2_ = 1 << 20, bi_ = -1; }
  HARVEST_SIMD_INLINE void take(int i, int j, int dist) {
    if (dist < b1_) {
      b2_ = b1_;
      b1_ = dist;
      bi_ = j;
    } else if (dist < b2_) {
      b2_ = dist;
    }
    if (dist < back_dist_[static_cast<std::size_t>(j)]) {
      back_dist_[static_cast<std::size_t>(j)] = dist;
      out_.back[static_cast<std::size_t>(j)] = i;
    }
  }
  HARVEST_SIMD_INLINE void end_row(int i) {
    out_.best[static_cast<std::size_t>(i)] = bi_;
    out_.best_dist[static_cast<std::size_t>(i)] = b1_;
    out_.second_dist[static_cast<std::size_t>(i)] = b2_;
  }

 private:
  Nearest& out_;
  std::vector<int> back_dist_;
  int b1_ = 1 << 20, b2_ = 1 << 20, bi_ = -1;
};

// Brute-force Hamming matching of 32-byte descriptors (ORB) in one pass over
// all pairs: for every desired descriptor the best and second-best current
// one (ratio test), for every current descriptor the best desired one
// (mutual check). Ties keep the lower index. Popcount is one instruction in
// the AVX2 build (the portable build counts bits in software); eight at a
// time with AVX-512 VPOPCNTDQ (below).
HARVEST_SIMD_INLINE void hamming_nearest_impl(const uint8_t* d, int nd, const uint8_t* c, int nc, Nearest& out) {
  NearestSelection sel(nd, nc, out);
  for (int i = 0; i < nd; ++i) {
    uint64_t a[4];
    std::memcpy(a, d + 32 * static_cast<std::size_t>(i), 32);
    sel.begin_row();
    for (int j = 0; j < nc; ++j) {
      uint64_t b[4];
      std::memcpy(b, c + 32 * static_cast<std::size_t>(j), 32);
      sel.take(i, j,
               __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
                   __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]));
    }
    sel.end_row(i);
  }
}
HARVEST_SIMD_DISPATCH(hamming_nearest_2, hamming_nearest_impl, void,
                      (const uint8_t* d, int nd, const uint8_t* c, int nc, Nearest& out), (d, nd, c, nc, out))

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
// The same with AVX-512 VPOPCNTDQ (a popcount of eight 64-bit words per
// instruction) where the CPU has it: the current descriptors word by word
// (word k of descriptor j at w[k n8 + j]), eight distances at a time, then
// the same selection as above in the same order. Distances are integers, so
// the result is identical to the other builds'.
__attribute__((target("avx512f,avx512vpopcntdq"))) void hamming_nearest_vpopcnt(const uint8_t* d, int nd,
                                                                                const uint8_t* c, int nc,
                                                                                Nearest& out) {
  const auto n8 = static_cast<std::size_t>((nc + 7) / 8 * 8);
  std::vector<uint64_t> w(4 * n8, 0);
  for (std::size_t j = 0; j < static_cast<std::size_t>(nc); ++j)
    for (std::size_t k = 0; k < 4; ++k) std::memcpy(&w[k * n8 + j], c + 32 * j + 8 * k, 8);
  NearestSelection sel(nd, nc, out);
  std::vector<int64_t> dist(n8);
  for (int i = 0; i < nd; ++i) {
    uint64_t a[4];
    std::memcpy(a, d + 32 * static_cast<std::size_t>(i), 32);
    const __m512i a0 = _mm512_set1_epi64(static_cast<long long>(a[0])),
                  a1 = _mm512_set1_epi64(static_cast<long long>(a[1])),
                  a2 = _mm512_set1_epi64(static_cast<long long>(a[2])),
                  a3 = _mm512_set1_epi64(static_cast<long long>(a[3]));
    for (std::size_t j = 0; j < n8; j += 8) {
      __m512i s = _mm512_popcnt_epi64(_mm512_xor_si512(a0, _mm512_loadu_si512(&w[j])));
      s = _mm512_add_epi64(s, _mm512_popcnt_epi64(_mm512_xor_si512(a1, _mm512_loadu_si512(&w[n8 + j]))));
      s = _mm512_add_epi64(s, _mm512_popcnt_epi64(_mm512_xor_si512(a2, _mm512_loadu_si512(&w[2 * n8 + j]))));
      s = _mm512_add_epi64(s, _mm512_popcnt_epi64(_mm512_xor_si512(a3, _mm512_loadu_si512(&w[3 * n8 + j]))));
      _mm512_storeu_si512(&dist[j], s);
    }
    sel.begin_row();
    for (int j = 0; j < nc; ++j) sel.take(i, j, static_cast<int>(dist[static_cast<std::size_t>(j)]));
    sel.end_row(i);
  }
}
#endif

}  // namespace

namespace detail {
void hamming_nearest(bool simd, const uint8_t* d, int nd, const uint8_t* c, int nc, Nearest& out) {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  static const bool vpopcnt = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vpopcntdq");
  if (simd && vpopcnt) return hamming_nearest_vpopcnt(d, nd, c, nc, out);
#endif
  hamming_nearest_2(simd, d, nd, c, nc, out);
}
}  // namespace detail

namespace {

// The current image seen through G (desired px -> current px) around each
// desired point: tile k (side 2 half + 1, tiles side by side in rows of
// 16) holds current(G(o_k + (i, j))), o_k = floor(p_k) - half: what a warp
// of the whole image (warpPerspective, WARP_INVERSE_MAP, border 0) holds
// there, by the same bilinear remap. Only the pixels that the refinement's
// windows read are computed.
cv::Mat1b warp_tiles(const cv::Mat1b& cur, const cv::Matx33d& G, const std::vector<cv::Point2f>& pts, int half,
                     std::vector<cv::Point>& origin, std::vector<cv::Point>& tile) {
  const int side = 2 * half + 1, n = static_cast<int>(pts.size());
  const int per_row = std::max(1, std::min(n, 16));
  const cv::Size size(per_row * side, std::max(1, (n + per_row - 1) / per_row) * side);
  cv::Mat1f mx(size, -1e6f), my(size, -1e6f);  // unused tiles: outside, border 0
  origin.resize(pts.size());
  tile.resize(pts.size());
  for (int k = 0; k < n; ++k) {
    const auto ku = static_cast<std::size_t>(k);
    const cv::Point o(cvFloor(pts[ku].x) - half, cvFloor(pts[ku].y) - half);
    const cv::Point t((k % per_row) * side, (k / per_row) * side);
    origin[ku] = o;
    tile[ku] = t;
    for (int j = 0; j < side; ++j) {
      float* rx = mx.ptr<float>(t.y + j) + t.x;
      float* ry = my.ptr<float>(t.y + j) + t.x;
      const double y = o.y + j;
      const double X0 = G(0, 0) * o.x + G(0, 1) * y + G(0, 2), Y0 = G(1, 0) * o.x + G(1, 1) * y + G(1, 2),
                   W0 = G(2, 0) * o.x + G(2, 1) * y + G(2, 2);
      for (int i = 0; i < side; ++i) {
        const double w = W0 + G(2, 0) * i;
        const double iw = w > 0 ? 1.0 / w : 0.0;  // behind the camera: outside
        rx[i] = w > 0 ? static_cast<float>((X0 + G(0, 0) * i) * iw) : -1e6f;
        ry[i] = w > 0 ? static_cast<float>((Y0 + G(1, 0) * i) * iw) : -1e6f;
      }
    }
  }
  cv::Mat1b out;
  cv::remap(cur, out, mx, my, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  return out;
}

// Margin around the followed corners so their windows stay inside the box
// at every pyramid level.
int box_margin(const MatcherParams& p) { return (p.refine_lk.window / 2 + 3) << std::max(p.track_levels - 1, 0); }

LkParams track_lk_params(const MatcherParams& p) {
  LkParams lp = p.refine_lk;
  lp.levels = std::max(p.track_levels, 1);
  return lp;
}

}  // namespace

DesiredImageMatcher::DesiredImageMatcher(MatcherParams params) : params_(std::move(params)) {
  params_.min_inliers = std::max(params_.min_inliers, 4);
  orb_ = cv::ORB::create(params_.orb_features, static_cast<float>(params_.orb_scale), params_.orb_levels, 31, 0, 2,
                         cv::ORB::HARRIS_SCORE, 31, params_.fast_threshold);
  orb_current_ =
      cv::ORB::create(params_.current_features, static_cast<float>(params_.orb_scale), params_.current_levels, 31, 0, 2,
                      cv::ORB::HARRIS_SCORE, 31, params_.current_fast_threshold);
}

void DesiredImageMatcher::set_desired(const cv::Mat1b& gray, const cv::Rect& region) {
  desired_ = gray.clone();
  desired_kp_.clear();
  desired_desc_.release();
  orb_->detectAndCompute(desired_, region_mask(gray.size(), region), desired_kp_, desired_desc_);
  desired_pyr_ = params_.refine ? Pyramid(desired_, params_.refine_lk.levels) : Pyramid();
  last_G_.reset();
  corners_.clear();
  box_ = {};
  box_pyr_ = Pyramid();
  if (!params_.track) return;
  CornerParams cp;
  cp.window = 7;
  cp.min_eigenvalue = 0;
  cp.quality_level = 0.01;
  cp.min_distance = 8;
  cp.max_corners = params_.track_corners;
  cp.border = params_.refine_lk.window / 2 + 2;
  for (const auto& c : detect_corners(desired_, cp, region)) corners_.push_back(c.pt);
  if (corners_.empty()) return;
  const cv::Rect hull = cv::boundingRect(corners_);
  const int m = box_margin(params_);
  box_ = cv::Rect(hull.x - m, hull.y - m, hull.width + 2 * m, hull.height + 2 * m) &
         cv::Rect(0, 0, desired_.cols, desired_.rows);
  box_pyr_ = Pyramid(desired_(box_).clone(), std::max(params_.track_levels, 1));
}

MatchResult DesiredImageMatcher::match(const cv::Mat1b& current, const cv::Rect& region, const Disc& face) {
  MatchResult r;
  if (last_G_ && params_.track && !corners_.empty()) {
    r = track(current, region, face, *last_G_);
    if (r.ok()) {
      last_G_ = r.G;
      return r;
    }
  }
  r = detect(current, region, face);
  if (r.ok())
    last_G_ = r.G;
  else
    last_G_.reset();
  return r;
}

MatchResult DesiredImageMatcher::track(const cv::Mat1b& current, const cv::Rect& region, const Disc& face,
                                       const cv::Matx33d& G) const {
  MatchResult r;
  r.tracked = true;
  // The box of the desired image, seen in the current image through G
  // (box pixel -> desired pixel -> current pixel).
  const cv::Matx33d to_current = G * cv::Matx33d(1, 0, box_.x, 0, 1, box_.y, 0, 0, 1);
  cv::Mat1b warped;
  cv::warpPerspective(current, warped, cv::Mat(to_current), box_.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  const LkParams lp = track_lk_params(params_);
  const Pyramid wp(warped, lp.levels);
  std::vector<cv::Point2f> local(corners_.size());
  for (std::size_t i = 0; i < corners_.size(); ++i) local[i] = corners_[i] - cv::Point2f(box_.tl());
  const auto res = track_lk(box_pyr_, wp, local, lp);
  std::vector<cv::Point2f> cand_d, cand_c;
  for (std::size_t i = 0; i < corners_.size(); ++i) {
    if (!res[i].found) continue;
    const cv::Point2f c = apply(to_current, res[i].pt);
    if (region.area() > 0 && !region.contains(cv::Point(cvFloor(c.x), cvFloor(c.y)))) continue;
    if (!face.empty() && !face.contains(c)) continue;
    cand_d.push_back(corners_[i]);
    cand_c.push_back(c);
  }
  r.num_candidates = static_cast<int>(cand_d.size());
  const int need =
      std::max(params_.min_inliers,
               static_cast<int>(std::ceil(params_.track_min_fraction * static_cast<double>(corners_.size()))));
  if (r.num_candidates < need) {
    r.status = MatchStatus::kTooFew;
    r.text = std::to_string(r.num_candidates) + " of " + std::to_string(corners_.size()) + " corners followed";
    return r;
  }
  geo::RansacParams rp;
  rp.threshold_px = params_.ransac_threshold_px;
  rp.max_iterations = params_.ransac_iterations;
  rp.seed = params_.seed;
  const auto fit = geo::fit_homography_robust(to_eigen(cand_d), to_eigen(cand_c), rp);
  if (!fit.ok() || fit.num_inliers < need) {
    r.status = fit.status == geo::Status::kDegenerate ? MatchStatus::kDegenerate : MatchStatus::kTooFew;
    r.text = std::to_string(fit.num_inliers) + " of " + std::to_string(corners_.size()) +
             " followed corners consistent with one homography";
    return r;
  }
  std::vector<cv::Point2f> out_d, out_c;
  for (std::size_t i = 0; i < cand_d.size(); ++i) {
    if (fit.inliers[i]) {
      r.desired.push_back(cand_d[i]);
      r.current.push_back(cand_c[i]);
    } else {
      out_d.push_back(cand_d[i]);
      out_c.push_back(cand_c[i]);
    }
  }
  r.status = MatchStatus::kOk;
  r.num_inliers = fit.num_inliers;
  r.rms_px = fit.rms_error_px;
  r.G = to_cv(fit.G);
  r.text = std::to_string(r.num_inliers) + " of " + std::to_string(corners_.size()) + " corners followed and verified";
  r.desired.insert(r.desired.end(), out_d.begin(), out_d.end());
  r.current.insert(r.current.end(), out_c.begin(), out_c.end());
  return r;
}

MatchResult DesiredImageMatcher::detect(const cv::Mat1b& current, const cv::Rect& region, const Disc& face) const {
  MatchResult r;
  if (desired_.empty()) {
    r.status = MatchStatus::kNoDesired;
    r.text = "no desired (zoomed) image received yet";
    return r;
  }
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  orb_current_->detectAndCompute(current, region_mask(current.size(), region), kp, desc);
  std::vector<cv::Point2f> cand_d, cand_c, off_d, off_c;  // off: outside the face
  if (!desc.empty() && !desired_desc_.empty()) {
    CV_Assert(desc.type() == CV_8U && desc.cols == 32 && desired_desc_.cols == 32 && desc.isContinuous() &&
              desired_desc_.isContinuous());
    Nearest nn;
    detail::hamming_nearest(true, desired_desc_.ptr<uint8_t>(), desired_desc_.rows, desc.ptr<uint8_t>(), desc.rows, nn);
    for (int i = 0; i < desired_desc_.rows; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const int j = nn.best[k];
      if (j < 0) continue;
      if (desc.rows > 1 && nn.best_dist[k] >= params_.ratio * nn.second_dist[k]) continue;
      if (params_.mutual && nn.back[static_cast<std::size_t>(j)] != i) continue;
      const cv::Point2f& c = kp[static_cast<std::size_t>(j)].pt;
      const bool on_face = face.empty() || face.contains(c);
      (on_face ? cand_d : off_d).push_back(desired_kp_[k].pt);
      (on_face ? cand_c : off_c).push_back(c);
    }
  }
  r.num_off_face = static_cast<int>(off_d.size());
  r.num_candidates = static_cast<int>(cand_d.size()) + r.num_off_face;
  // Matches off the face are reported after the rejected ones, never verified.
  const std::string off_it = r.num_off_face > 0 ? ", " + std::to_string(r.num_off_face) + " off it" : "";
  auto too_few = [&](const std::string& why) {
    r.status = MatchStatus::kTooFew;
    r.text = why;
    r.desired = cand_d;
    r.current = cand_c;
    r.desired.insert(r.desired.end(), off_d.begin(), off_d.end());
    r.current.insert(r.current.end(), off_c.begin(), off_c.end());
    r.num_inliers = 0;
    return r;
  };
  const int on_face = static_cast<int>(cand_d.size());
  if (on_face < 4)
    return too_few(std::to_string(on_face) + " descriptor matches" + (face.empty() ? "" : " on the fruit's face") +
                   off_it + " (" + std::to_string(desired_kp_.size()) + " desired, " + std::to_string(kp.size()) +
                   " current keypoints); need >= 4 for a homography");

  geo::RansacParams rp;
  rp.threshold_px = params_.ransac_threshold_px;
  rp.max_iterations = params_.ransac_iterations;
  rp.seed = params_.seed;
  auto fit = geo::fit_homography_robust(to_eigen(cand_d), to_eigen(cand_c), rp);
  if (fit.status == geo::Status::kDegenerate) {
    r.status = MatchStatus::kDegenerate;
    r.text = "matches are degenerate (collinear or coincident)";
    r.desired = cand_d;
    r.current = cand_c;
    r.desired.insert(r.desired.end(), off_d.begin(), off_d.end());
    r.current.insert(r.current.end(), off_c.begin(), off_c.end());
    return r;
  }
  if (!fit.ok() || fit.num_inliers < params_.min_inliers)
    return too_few(std::to_string(fit.num_inliers) + " of " + std::to_string(on_face) + " matches" +
                   (face.empty() ? "" : " on the fruit's face") + " consistent with one homography" + off_it +
                   "; need >= " + std::to_string(params_.min_inliers));

  std::vector<cv::Point2f> in_d, in_c, out_d, out_c;
  for (std::size_t i = 0; i < cand_d.size(); ++i) {
    if (fit.inliers[i]) {
      in_d.push_back(cand_d[i]);
      in_c.push_back(cand_c[i]);
    } else {
      out_d.push_back(cand_d[i]);
      out_c.push_back(cand_c[i]);
    }
  }
  cv::Matx33d G = to_cv(fit.G);

  if (params_.refine && !desired_pyr_.empty()) {
    // The current image warped into the desired one, only around the
    // inliers (tiles); what remains there is a small residual
    // displacement that Lucas-Kanade measures to sub-pixel.
    // A tile holds the window, moved by up to refine_max_shift_px, and
    // the bilinear interpolation's next pixel.
    const int half = params_.refine_lk.window / 2 + static_cast<int>(std::ceil(params_.refine_max_shift_px)) + 1;
    std::vector<cv::Point> origin, tile;
    const cv::Mat1b tiles = warp_tiles(current, G, in_d, half, origin, tile);
    const Pyramid wp(tiles, 1);
    LkParams lp = params_.refine_lk;
    lp.levels = 1;  // a tile holds the neighbourhood of one level
    std::vector<cv::Point2f> guesses(in_d.size());
    for (std::size_t i = 0; i < in_d.size(); ++i) guesses[i] = in_d[i] - cv::Point2f(origin[i] - tile[i]);
    const auto res = track_lk(desired_pyr_, wp, in_d, lp, guesses);
    std::vector<cv::Point2f> rd, rc;
    for (std::size_t i = 0; i < in_d.size(); ++i) {
      const auto& t = res[i];
      if (!t.found) continue;
      const cv::Point2f q = t.pt + cv::Point2f(origin[i] - tile[i]);  // desired px
      const float sx = q.x - in_d[i].x, sy = q.y - in_d[i].y;
      if (sx * sx + sy * sy > params_.refine_max_shift_px * params_.refine_max_shift_px) continue;
      rd.push_back(in_d[i]);
      rc.push_back(apply(G, q));
    }
    if (static_cast<int>(rd.size()) >= params_.min_inliers) {
      auto refit = geo::fit_homography_robust(to_eigen(rd), to_eigen(rc), rp);
      if (refit.ok() && refit.num_inliers >= params_.min_inliers) {
        std::vector<cv::Point2f> fd, fc;
        for (std::size_t i = 0; i < rd.size(); ++i)
          if (refit.inliers[i]) {
            fd.push_back(rd[i]);
            fc.push_back(rc[i]);
          }
        in_d = std::move(fd);
        in_c = std::move(fc);
        fit = refit;
        G = to_cv(refit.G);
      }
    }
  }

  r.status = MatchStatus::kOk;
  r.num_inliers = static_cast<int>(in_d.size());
  r.rms_px = fit.rms_error_px;
  r.G = G;
  r.text = std::to_string(r.num_inliers) + " of " + std::to_string(r.num_candidates) + " matches verified" +
           (r.num_off_face > 0 ? ", " + std::to_string(r.num_off_face) + " off the fruit's face" : "");
  r.desired = std::move(in_d);
  r.current = std::move(in_c);
  r.desired.insert(r.desired.end(), out_d.begin(), out_d.end());
  r.current.insert(r.current.end(), out_c.begin(), out_c.end());
  r.desired.insert(r.desired.end(), off_d.begin(), off_d.end());
  r.current.insert(r.current.end(), off_c.begin(), off_c.end());
  return r;
}

}  // namespace harvest::features
