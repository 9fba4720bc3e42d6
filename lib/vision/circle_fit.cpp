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
  // conditioned). The sums are written out: the same products added in the
  // same order as Eigen's `ata += row * row.transpose()` (so the same bits),
  // without forming a 3x3 outer product per point; the symmetric entries
  // once (x y and y x are the same double).
  double sxx = 0, sxy = 0, sx = 0, syy = 0, sy = 0, s1 = 0, bx = 0, by = 0, b1 = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = points[i].x - mean.x, y = points[i].y - mean.y;
    const double z = x * x + y * y;
    sxx += x * x, sxy += x * y, sx += x, syy += y * y, sy += y, s1 += 1.0;
    bx -= x * z, by -= y * z, b1 -= z;
  }
  Eigen::Matrix3d ata;
  ata << sxx, sxy, sx, sxy, syy, sy, sx, sy, s1;
  const Eigen::Vector3d atb(bx, by, b1);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  if (lu.rank() < 3) return std::nullopt;
  const Eigen::Vector3d s = lu.solve(atb);
  double cx = -s(0) / 2, cy = -s(1) / 2;
  const double r2 = cx * cx + cy * cy - s(2);
  if (!(r2 > 0)) return std::nullopt;
  double r = std::sqrt(r2);

  // Gauss-Newton on residuals d_i = |p_i - c| - r; the Jacobian row is
  // (-dx / d, -dy / d, -1), its products with -1 written as negations (exact).
  for (int it = 0; it < iterations; ++it) {
    double j00 = 0, j01 = 0, j02 = 0, j11 = 0, j12 = 0, j22 = 0, r0 = 0, r1 = 0, r2s = 0;
    for (const auto& p : points) {
      const double dx = p.x - mean.x - cx, dy = p.y - mean.y - cy;
      const double dist = std::sqrt(dx * dx + dy * dy);
      if (dist < 1e-12) continue;
      const double ja = -dx / dist, jb = -dy / dist;
      const double res = dist - r;
      j00 += ja * ja, j01 += ja * jb, j02 += -ja, j11 += jb * jb, j12 += -jb, j22 += 1.0;
      r0 += ja * res, r1 += jb * res, r2s += -res;
    }
    Eigen::Matrix3d jtj;
    jtj << j00, j01, j02, j01, j11, j12, j02, j12, j22;
    const Eigen::Vector3d jtr(r0, r1, r2s);
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
