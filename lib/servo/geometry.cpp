#include "servo/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace harvest::servo {

twist_t to_twist(const Eigen::Vector3d& linear, const Eigen::Vector3d& angular) {
  twist_t t{};
  for (int i = 0; i < 3; ++i) {
    t.linear[i] = linear[i];
    t.angular[i] = angular[i];
  }
  return t;
}

namespace {
// Eq. 6-21 exactly as written (these are the transposes of the right-handed
// rotations by alpha and beta; with alpha = atan(Y/Z) they turn z toward the target).
Eigen::Matrix3d thesis_rx(double a) {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a);
  return r;
}
Eigen::Matrix3d thesis_ry(double b) {
  Eigen::Matrix3d r;
  r << std::cos(b), 0, -std::sin(b), 0, 1, 0, std::sin(b), 0, std::cos(b);
  return r;
}
}  // namespace

Eigen::Matrix3d aim_rotation(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target_base, AimAngles* angles) {
  const Eigen::Matrix3d rf = tool.rotation();
  // Eq. 6-17: the target in the tool frame.
  const Eigen::Vector3d m = rf.transpose() * (target_base - tool.translation());
  const double alpha = std::atan2(m.y(), m.z());  // eq. 6-19
  const Eigen::Matrix3d rx = thesis_rx(alpha);
  const Eigen::Vector3d m1 = rx.transpose() * m;    // target after the x rotation
  const double beta = -std::atan2(m1.x(), m1.z());  // eq. 6-20
  if (angles != nullptr) *angles = {alpha, beta};
  return rf * rx * thesis_ry(beta);  // eq. 6-22 applied in sequence
}

double rotation_distance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

Eigen::Vector2d undistort_pixel(const geometry::CameraModel& cam, double u, double v) {
  // Inverse of the upper-triangular intrinsic matrix (eq. 6-6, 6-9).
  const double yd = (v - cam.cy) / cam.fy;
  const double xd = (u - cam.cx - cam.skew * yd) / cam.fx;
  const auto& d = cam.dist;
  double x = xd, y = yd;
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double dx = 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double dy = d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    x = (xd - dx) / radial;
    y = (yd - dy) / radial;
  }
  return {x, y};
}

bool project_point(const geometry::CameraModel& cam, const Eigen::Vector3d& p, Eigen::Vector2d& pixel) {
  if (p.z() <= 1e-6) return false;
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const auto& d = cam.dist;
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  pixel = {cam.fx * xd + cam.skew * yd + cam.cx, cam.fy * yd + cam.cy};
  return true;
}

std::vector<Eigen::Vector2d> project_segment(const geometry::CameraModel& cam, const Eigen::Isometry3d& camera,
                                             const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // 64 samples: at most a few pixels of chord error for a segment across the
  // whole image. Beyond 0.8 in normalised coordinates (about 39 deg, well
  // outside the image) the distortion polynomial is no longer a lens model.
  constexpr int kSamples = 64;
  constexpr double kMaxNormalised = 0.8;
  std::vector<Eigen::Vector2d> out;
  const Eigen::Isometry3d to_camera = camera.inverse();
  for (int i = 0; i <= kSamples; ++i) {
    const Eigen::Vector3d p = to_camera * (a + (b - a) * (static_cast<double>(i) / kSamples));
    if (p.z() <= 0.01 || std::abs(p.x()) > kMaxNormalised * p.z() || std::abs(p.y()) > kMaxNormalised * p.z()) continue;
    Eigen::Vector2d px;
    if (project_point(cam, p, px)) out.push_back(px);
  }
  return out;
}

std::optional<RayCrossing> cross_rays(const Eigen::Vector3d& o1, const Eigen::Vector3d& d1, const Eigen::Vector3d& o2,
                                      const Eigen::Vector3d& d2) {
  // Minimise |o1 + s d1 - o2 - t d2| over s, t (unit directions).
  const double b = d1.dot(d2);
  const double den = 1.0 - b * b;
  if (den < 1e-9) return std::nullopt;
  const Eigen::Vector3d w = o1 - o2;
  const double d = d1.dot(w), e = d2.dot(w);
  const double s = (b * e - d) / den, t = (e - b * d) / den;
  if (s <= 0.0 || t <= 0.0) return std::nullopt;
  const Eigen::Vector3d p1 = o1 + s * d1, p2 = o2 + t * d2;
  return RayCrossing{0.5 * (p1 + p2), (p1 - p2).norm(), std::acos(std::clamp(b, -1.0, 1.0))};
}

double distance_to_polyline(const std::vector<Eigen::Vector2d>& polyline, const Eigen::Vector2d& pixel) {
  if (polyline.empty()) return std::numeric_limits<double>::infinity();
  double best = (polyline.front() - pixel).norm();
  for (std::size_t i = 1; i < polyline.size(); ++i) {
    const Eigen::Vector2d d = polyline[i] - polyline[i - 1];
    const double len2 = d.squaredNorm();
    const double s = len2 > 0 ? std::clamp((pixel - polyline[i - 1]).dot(d) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (polyline[i - 1] + s * d - pixel).norm());
  }
  return best;
}

}  // namespace harvest::servo
