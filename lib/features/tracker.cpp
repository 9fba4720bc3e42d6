#include "features/tracker.hpp"

#include <algorithm>

namespace harvest::features {

FeatureTracker::FeatureTracker(TrackerParams params) : params_(std::move(params)) {}

void FeatureTracker::reset() {
  prev_ = Pyramid();
  tracks_.clear();
}

TrackerUpdate FeatureTracker::update(const cv::Mat1b& gray, const cv::Rect& region, const cv::Mat1b& mask) {
  TrackerUpdate u;
  Pyramid next(gray, params_.lk.levels);
  if (!prev_.empty() && prev_.level(0).size() != next.level(0).size()) {
    u.lost = static_cast<int>(tracks_.size());
    tracks_.clear();
  }
  if (!tracks_.empty() && !prev_.empty()) {
    std::vector<cv::Point2f> pts;
    pts.reserve(tracks_.size());
    for (const auto& t : tracks_) pts.push_back(t.pt);
    const auto res = track_lk(prev_, next, pts, params_.lk);
    const bool use_mask = !mask.empty() && mask.size() == gray.size();
    std::vector<Track> kept;
    kept.reserve(tracks_.size());
    for (std::size_t i = 0; i < tracks_.size(); ++i) {
      const auto& r = res[i];
      bool keep = r.found && r.error <= params_.max_error;
      if (keep && region.area() > 0) keep = region.contains(cv::Point(cvRound(r.pt.x), cvRound(r.pt.y)));
      if (keep && use_mask) keep = mask(cvRound(r.pt.y), cvRound(r.pt.x)) != 0;
      if (!keep) {
        ++u.lost;
        continue;
      }
      Track t = tracks_[i];
      t.pt = r.pt;
      t.error = r.error;
      ++t.age;
      kept.push_back(t);
    }
    tracks_ = std::move(kept);
  }
  if (static_cast<int>(tracks_.size()) < params_.min_features) {
    CornerParams cp = params_.corners;
    cp.max_corners = std::max(0, params_.max_features - static_cast<int>(tracks_.size()));
    if (cp.max_corners > 0) {
      std::vector<cv::Point2f> existing;
      for (const auto& t : tracks_) existing.push_back(t.pt);
      for (const auto& c : detect_corners(gray, cp, region, mask, existing)) {
        Track t;
        t.id = next_id_++;
        t.pt = c.pt;
        t.quality = c.min_eigenvalue;
        tracks_.push_back(t);
        ++u.added;
      }
    }
  }
  prev_ = std::move(next);
  return u;
}

}  // namespace harvest::features
