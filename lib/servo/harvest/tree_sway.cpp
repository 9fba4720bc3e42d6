#include "servo/harvest/tree_sway.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace harvest::servo {

void TreeSwayGauge::add(const targets_t& fixed) {
  if (!enabled() || fixed.source_camera != "fixed") return;
  const double t = static_cast<double>(fixed.header.utime) * 1e-6;
  for (const target_t& target : fixed.targets) {
    // A size of nothing gives no scale: the view is not counted.
    if (!(target.diameter_px > 0.0f) || !(target.diameter_m > 0.0) || !std::isfinite(target.u_px) ||
        !std::isfinite(target.v_px))
      continue;
    auto it = views_.find(target.fruit_id);
    if (it == views_.end()) {
      if (static_cast<int>(views_.size()) >= kMaxFruit) continue;
      it = views_.emplace(target.fruit_id, std::deque<View>{}).first;
    }
    it->second.push_back({t, target.u_px, target.v_px, target.diameter_m / target.diameter_px});
  }
  if (t >= updated_ + kEvery_s || t < updated_) update(t);
}

void TreeSwayGauge::update(double now) {
  updated_ = now;
  std::vector<double> spreads;
  for (auto it = views_.begin(); it != views_.end();) {
    auto& v = it->second;
    while (!v.empty() && v.front().t < now - p_.tree_window) v.pop_front();
    if (v.empty()) {
      it = views_.erase(it);
      continue;
    }
    if (v.back().t - v.front().t >= p_.tree_min_span && v.size() >= 2) {
      // rms distance of the centroids from their mean, in metres at the fruit (the median scale: one
      // size cut by a leaf must not scale the whole spread).
      double su = 0, sv = 0;
      for (const View& w : v) su += w.u - v.front().u, sv += w.v - v.front().v;
      const double n = static_cast<double>(v.size());
      const double mu = su / n, mv = sv / n;
      double ss = 0;
      std::vector<double> scale;
      scale.reserve(v.size());
      for (const View& w : v) {
        const double du = w.u - v.front().u - mu, dv = w.v - v.front().v - mv;
        ss += du * du + dv * dv;
        scale.push_back(w.metres_per_px);
      }
      std::nth_element(scale.begin(), scale.begin() + scale.size() / 2, scale.end());
      spreads.push_back(std::sqrt(ss / n) * scale[scale.size() / 2]);
    }
    ++it;
  }
  reading_ = Reading{};
  reading_.fruit = static_cast<int>(spreads.size());
  if (reading_.fruit < std::max(1, p_.tree_min_fruit)) return;
  const auto k = static_cast<size_t>(std::floor(p_.tree_quantile * static_cast<double>(spreads.size() - 1)));
  std::nth_element(spreads.begin(), spreads.begin() + static_cast<std::ptrdiff_t>(k), spreads.end());
  reading_.rms = spreads[k];
  reading_.verdict = reading_.rms < p_.tree_still_rms ? Verdict::kStill : Verdict::kSwaying;
}

}  // namespace harvest::servo
