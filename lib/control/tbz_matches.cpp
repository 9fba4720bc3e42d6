#include "control/tbz_matches.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace harvest::control {

namespace geo = harvest::geometry;

MatchMeasurement measurement_from_matches(const geo::Points2& desired, const geo::Points2& current,
                                          geo::Points2& anchors) {
  MatchMeasurement out;
  out.pairs = static_cast<int>(std::min(desired.size(), current.size()));
  if (desired.size() != current.size() || desired.size() < 4) {
    out.message = "need >= 4 verified matches, have " + std::to_string(out.pairs);
    return out;
  }
  const auto fit = geo::fit_homography(desired, current);
  if (!fit.ok()) {
    out.message = std::string("matches: ") + geo::to_string(fit.status);
    return out;
  }
  if (anchors.empty()) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : desired) c += p;
    c /= static_cast<double>(desired.size());
    double spread = 0;
    for (const auto& p : desired) spread += (p - c).squaredNorm();
    const double h = 0.5 * std::sqrt(spread / static_cast<double>(desired.size()));
    if (!(h > 1e-6)) {
      out.message = "matches have no spread";
      return out;
    }
    anchors = {c, c + Eigen::Vector2d(-h, -h), c + Eigen::Vector2d(h, -h), c + Eigen::Vector2d(h, h),
               c + Eigen::Vector2d(-h, h)};
  }
  out.measurement.desired_px = anchors;
  for (const auto& a : anchors) {
    const Eigen::Vector3d q = fit.G * a.homogeneous();
    if (!(q.z() > 1e-12) || !q.allFinite()) {
      out.message = "an anchor maps to infinity";
      return out;
    }
    out.measurement.current_px.push_back(q.hnormalized());
  }
  out.ok = true;
  return out;
}

}  // namespace harvest::control
