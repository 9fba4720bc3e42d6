#include "vision/circle_fit.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace harvest::vision {

std::optional<Circle> fit_circle(const std::vector<cv::Point2d>& points, int iterations) {
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 3) return std::nullopt;
  // Centre the data for conditioning.
  cv::Point2d mean(0, 0);
  for (const auto& p : points) mean += p;
  mean *= 1.0 / static_cast<double>(n);

  // Kasa: x^2 + y^2 + a x + b y + c = 0, linear least squares through the
  // 3x3 normal equations (the data are centred, so they are well
  // conditioned; no per-call allocation, the detector fits many circles).
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = points[i].x - mean.x, y = points[i].y - mean.y;
    const Eigen::Vector3d row(x, y, 1.0);
    ata += row * row.transpose();
    atb -= row * (x * x + y * y);
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  if (lu.rank() < 3) return std::nullopt;
  const Eigen::Vector3d s = lu.solve(atb);
  double cx = -s(0) / 2, cy = -s(1) / 2;
  const double r2 = cx * cx + cy * cy - s(2);
  if (!(r2 > 0)) return std::nullopt;
  double r = std::sqrt(r2);

  // Gauss-Newton on residuals d_i = |p_i - c| - r.
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (const auto& p : points) {
      const double dx = p.x - mean.x - cx, dy = p.y - mean.y - cy;
      const double dist = std::sqrt(dx * dx + dy * dy);
      if (dist < 1e-12) continue;
      const Eigen::Vector3d j(-dx / dist, -dy / dist, -1.0);
      const double res = dist - r;
      jtj += j * j.transpose();
      jtr += j * res;
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) break;
    cx += step(0);
    cy += step(1);
    r += step(2);
    if (step.norm() < 1e-6) break;  // pixels: far below what matters
  }
  if (!(r > 0) || !std::isfinite(r)) return std::nullopt;
  double ss = 0;
  for (const auto& p : points) {
    const double ex = p.x - mean.x - cx, ey = p.y - mean.y - cy;
    const double res = std::sqrt(ex * ex + ey * ey) - r;
    ss += res * res;
  }
  return Circle{cx + mean.x, cy + mean.y, r, std::sqrt(ss / static_cast<double>(n))};
}

}  // namespace harvest::vision
