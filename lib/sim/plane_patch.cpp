#include "sim/plane_patch.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::sim {

void draw_plane_patch(Renderer::Canvas& canvas, const PlanePatch& p, const PatchAlbedo& albedo) {
  const Vec3& o = p.origin;
  const Vec3& n = p.normal;
  // Corners -> normalised box.
  double ax = 1e30, bx = -1e30, ay = 1e30, by = -1e30;
  for (const double u : {p.u0, p.u1})
    for (const double v : {p.v0, p.v1}) {
      const Vec3 q = o + u * p.ex + v * p.ey;
      if (q.z() <= 0.01) return;
      ax = std::min(ax, q.x() / q.z());
      bx = std::max(bx, q.x() / q.z());
      ay = std::min(ay, q.y() / q.z());
      by = std::max(by, q.y() / q.z());
    }
  const Renderer::PixelBox b =
      canvas.pixels(static_cast<float>(ax), static_cast<float>(bx), static_cast<float>(ay), static_cast<float>(by));
  const double nc = n.dot(o);
  const bool front = nc > 0.0;  // the camera is on the -n side
  const Eigen::Vector3f normal = (front ? n : -n).cast<float>();
  const int w = canvas.width(), h = canvas.height();
  for (int y = b.y0; y <= b.y1; ++y) {
    for (int x = b.x0; x <= b.x1; ++x) {
      const int i = y * w + x;
      const Eigen::Vector3d d = canvas.ray(i).cast<double>();
      const double nd = n.dot(d);
      if (std::abs(nd) < 1e-9) continue;
      const double depth = nc / nd;
      const Vec3 q = depth * d - o;
      const double u = q.dot(p.ex), v = q.dot(p.ey);
      if (u < p.u0 || v < p.v0 || u > p.u1 || v > p.v1) continue;
      Vec3 sum = Vec3::Zero();
      if (front) {
        // Sub-pixel rays from the neighbours' (the ray field is smooth).
        const int ix = x + 1 < w ? i + 1 : i - 1, iy = y + 1 < h ? i + w : i - w;
        const Eigen::Vector3d dx = (canvas.ray(ix).cast<double>() - d) * (x + 1 < w ? 1.0 : -1.0);
        const Eigen::Vector3d dy = (canvas.ray(iy).cast<double>() - d) * (y + 1 < h ? 1.0 : -1.0);
        for (int k = 0; k < p.samples; ++k) {
          const int sy = (k * p.stride) % p.samples;
          const Eigen::Vector3d ds = d + ((k + 0.5) / p.samples - 0.5) * dx + ((sy + 0.5) / p.samples - 0.5) * dy;
          const Vec3 qs = (nc / n.dot(ds)) * ds - o;
          sum += albedo(qs.dot(p.ex), qs.dot(p.ey), true);
        }
        sum /= p.samples;
      } else {
        sum = albedo(u, v, false);
      }
      canvas.put(i, static_cast<float>(depth), sum, normal);
    }
  }
}

}  // namespace harvest::sim
