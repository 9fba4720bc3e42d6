#include "geometry/pose_history.hpp"

#include <algorithm>
#include <cstdlib>

namespace harvest::geometry {

void PoseHistory::add(int64_t utime, const Eigen::Isometry3d& pose) {
  const Sample s{utime, pose.translation(), Eigen::Quaterniond(pose.linear()).normalized()};
  auto it =
      std::lower_bound(samples_.begin(), samples_.end(), utime, [](const Sample& a, int64_t t) { return a.utime < t; });
  if (it != samples_.end() && it->utime == utime)
    *it = s;
  else
    samples_.insert(it, s);
  while (samples_.size() > capacity_) samples_.pop_front();
}

std::optional<Eigen::Isometry3d> PoseHistory::at(int64_t utime, int64_t max_gap_us) const {
  if (samples_.empty()) return std::nullopt;
  auto make = [](const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = q.toRotationMatrix();
    t.translation() = p;
    return t;
  };
  const auto after =
      std::lower_bound(samples_.begin(), samples_.end(), utime, [](const Sample& a, int64_t t) { return a.utime < t; });
  if (after != samples_.end() && after->utime == utime) return make(after->p, after->q);
  if (after != samples_.begin() && after != samples_.end()) {
    const Sample& a = *(after - 1);
    const Sample& b = *after;
    if (b.utime - a.utime <= max_gap_us) {
      const double s = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
      return make(a.p + s * (b.p - a.p), a.q.slerp(s, b.q));
    }
  }
  const Sample& nearest = after == samples_.end() ? samples_.back()
                          : after == samples_.begin()
                              ? samples_.front()
                              : (utime - (after - 1)->utime <= after->utime - utime ? *(after - 1) : *after);
  if (std::llabs(nearest.utime - utime) * 2 <= max_gap_us) return make(nearest.p, nearest.q);
  return std::nullopt;
}

}  // namespace harvest::geometry
