#include "vision/tracking.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <tuple>

namespace harvest::vision {

std::vector<int32_t> PixelTracker::update(const std::vector<PixelObservation>& detections) {
  struct Pair {
    double dist;
    std::size_t track, det;
  };
  std::vector<Pair> pairs;
  for (std::size_t t = 0; t < tracks_.size(); ++t)
    for (std::size_t d = 0; d < detections.size(); ++d) {
      const auto& a = tracks_[t].last;
      const auto& b = detections[d];
      const double dist = std::hypot(a.u - b.u, a.v - b.v);
      if (dist <= gate_ * std::max(a.diameter_px, b.diameter_px)) pairs.push_back({dist, t, d});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.dist, a.track, a.det) < std::tie(b.dist, b.track, b.det);
  });
  std::vector<int32_t> ids(detections.size(), -1);
  std::vector<bool> track_used(tracks_.size(), false);
  for (const Pair& p : pairs) {
    if (track_used[p.track] || ids[p.det] >= 0) continue;
    track_used[p.track] = true;
    ids[p.det] = tracks_[p.track].id;
    tracks_[p.track].last = detections[p.det];
    tracks_[p.track].missed = 0;
  }
  for (std::size_t t = 0; t < tracks_.size(); ++t)
    if (!track_used[t]) ++tracks_[t].missed;
  std::erase_if(tracks_, [this](const Track& t) { return t.missed > max_missed_; });
  for (std::size_t d = 0; d < detections.size(); ++d)
    if (ids[d] < 0) {
      ids[d] = next_id_++;
      tracks_.push_back({ids[d], detections[d], 0});
    }
  return ids;
}

bool PixelTracker::alive(int32_t id) const {
  return std::any_of(tracks_.begin(), tracks_.end(), [id](const Track& t) { return t.id == id; });
}

double mahalanobis2(const Estimate3d& a, const Estimate3d& b) {
  const Eigen::Matrix3d s = a.covariance + b.covariance;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(s);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d d = a.position - b.position;
  return d.dot(ldlt.solve(d));
}

std::vector<std::optional<int32_t>> HandAssociator::associate(const std::vector<int32_t>& hand_track_ids,
                                                              const std::vector<Estimate3d>& hand_estimates,
                                                              const std::map<int32_t, Estimate3d>& fruit) {
  std::vector<std::optional<int32_t>> out(hand_track_ids.size());
  std::set<int32_t> taken;
  for (std::size_t i = 0; i < hand_track_ids.size(); ++i) {
    const auto link = link_.find(hand_track_ids[i]);
    if (link != link_.end() && fruit.count(link->second) && !taken.count(link->second)) {
      out[i] = link->second;
      taken.insert(link->second);
    }
  }
  struct Pair {
    double d2;
    std::size_t det;
    int32_t fruit;
  };
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < hand_track_ids.size(); ++i) {
    if (out[i]) continue;
    for (const auto& [id, est] : fruit) {
      if (taken.count(id)) continue;
      const double d2 = mahalanobis2(hand_estimates[i], est);
      if (d2 <= gate_chi2_) pairs.push_back({d2, i, id});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(a.d2, a.det, a.fruit) < std::tie(b.d2, b.det, b.fruit);
  });
  for (const Pair& p : pairs) {
    if (out[p.det] || taken.count(p.fruit)) continue;
    out[p.det] = p.fruit;
    taken.insert(p.fruit);
    link_[hand_track_ids[p.det]] = p.fruit;
  }
  return out;
}

void HandAssociator::prune(const PixelTracker& hand_tracker) {
  std::erase_if(link_, [&](const auto& kv) { return !hand_tracker.alive(kv.first); });
}

}  // namespace harvest::vision
