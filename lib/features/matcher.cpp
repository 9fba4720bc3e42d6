#include "features/matcher.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "geometry/homography.hpp"

namespace harvest::features {

namespace geo = harvest::geometry;

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

}  // namespace

DesiredImageMatcher::DesiredImageMatcher(MatcherParams params) : params_(std::move(params)) {
  params_.min_inliers = std::max(params_.min_inliers, 4);
  orb_ = cv::ORB::create(params_.orb_features, static_cast<float>(params_.orb_scale), params_.orb_levels, 31, 0, 2,
                         cv::ORB::HARRIS_SCORE, 31, params_.fast_threshold);
}

void DesiredImageMatcher::set_desired(const cv::Mat1b& gray, const cv::Rect& region) {
  desired_ = gray.clone();
  desired_kp_.clear();
  desired_desc_.release();
  orb_->detectAndCompute(desired_, region_mask(gray.size(), region), desired_kp_, desired_desc_);
  desired_pyr_ = params_.refine ? Pyramid(desired_, params_.refine_lk.levels) : Pyramid();
}

MatchResult DesiredImageMatcher::match(const cv::Mat1b& current, const cv::Rect& region) const {
  MatchResult r;
  if (desired_.empty()) {
    r.status = MatchStatus::kNoDesired;
    r.text = "no desired (zoomed) image received yet";
    return r;
  }
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  orb_->detectAndCompute(current, region_mask(current.size(), region), kp, desc);
  std::vector<cv::Point2f> cand_d, cand_c;
  if (!desc.empty() && !desired_desc_.empty()) {
    cv::BFMatcher bf(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> fwd;
    bf.knnMatch(desired_desc_, desc, fwd, 2);
    std::vector<int> back;
    if (params_.mutual) {
      std::vector<cv::DMatch> bwd;
      bf.match(desc, desired_desc_, bwd);
      back.assign(kp.size(), -1);
      for (const auto& m : bwd) back[static_cast<std::size_t>(m.queryIdx)] = m.trainIdx;
    }
    for (const auto& m : fwd) {
      if (m.empty()) continue;
      if (m.size() > 1 && m[0].distance >= params_.ratio * m[1].distance) continue;
      if (params_.mutual && back[static_cast<std::size_t>(m[0].trainIdx)] != m[0].queryIdx) continue;
      cand_d.push_back(desired_kp_[static_cast<std::size_t>(m[0].queryIdx)].pt);
      cand_c.push_back(kp[static_cast<std::size_t>(m[0].trainIdx)].pt);
    }
  }
  r.num_candidates = static_cast<int>(cand_d.size());
  auto too_few = [&](const std::string& why) {
    r.status = MatchStatus::kTooFew;
    r.text = why;
    r.desired = cand_d;
    r.current = cand_c;
    r.num_inliers = 0;
    return r;
  };
  if (r.num_candidates < 4)
    return too_few(std::to_string(r.num_candidates) + " descriptor matches (" + std::to_string(desired_kp_.size()) +
                   " desired, " + std::to_string(kp.size()) + " current keypoints); need >= 4 for a homography");

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
    return r;
  }
  if (!fit.ok() || fit.num_inliers < params_.min_inliers)
    return too_few(std::to_string(fit.num_inliers) + " of " + std::to_string(r.num_candidates) +
                   " matches consistent with one homography; need >= " + std::to_string(params_.min_inliers));

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
    // Warp the current image into the desired one; what remains is a small
    // residual displacement that Lucas-Kanade measures to sub-pixel.
    cv::Mat1b warped;
    cv::warpPerspective(current, warped, cv::Mat(G), desired_.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                        cv::BORDER_CONSTANT, 0);
    const Pyramid wp(warped, params_.refine_lk.levels);
    const auto res = track_lk(desired_pyr_, wp, in_d, params_.refine_lk);
    std::vector<cv::Point2f> rd, rc;
    for (std::size_t i = 0; i < in_d.size(); ++i) {
      const auto& t = res[i];
      if (!t.found) continue;
      const float sx = t.pt.x - in_d[i].x, sy = t.pt.y - in_d[i].y;
      if (sx * sx + sy * sy > params_.refine_max_shift_px * params_.refine_max_shift_px) continue;
      rd.push_back(in_d[i]);
      rc.push_back(apply(G, t.pt));
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
  r.text = std::to_string(r.num_inliers) + " of " + std::to_string(r.num_candidates) + " matches verified";
  r.desired = std::move(in_d);
  r.current = std::move(in_c);
  r.desired.insert(r.desired.end(), out_d.begin(), out_d.end());
  r.current.insert(r.current.end(), out_c.begin(), out_c.end());
  return r;
}

}  // namespace harvest::features
