// Synthetic test images: spheres rendered through a CameraModel by ray
// casting (a pixel is fruit if the ray through its centre hits the sphere),
// discs and leaves drawn in image space.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <utility>

#include "geometry/camera_model.hpp"
#include "vision/segmentation.hpp"

namespace harvest::vision::test {

// Threshold boxes for comparing threshold kernels: case 0 the thesis box,
// then random bounds in [-300, 300] (every seventh case possibly empty
// ranges), and case `last` everything (+-1e7, clamped to +-1e6) inside.
inline ColorThresholds random_thresholds(std::mt19937& rng, int k, int last) {
  if (k == last) return {-1e7, 1e7, -1e7, 1e7, -1e7, 1e7};
  if (k == 0) return {};
  std::uniform_real_distribution<double> bound(-300, 300);
  double a = bound(rng), b = bound(rng), c = bound(rng), d = bound(rng), e = bound(rng), f = bound(rng);
  if (k % 7 != 0) {  // mostly proper ranges, sometimes empty ones
    if (a > b) std::swap(a, b);
    if (c > d) std::swap(c, d);
    if (e > f) std::swap(e, f);
  }
  return {a, b, c, d, e, f};
}

inline const cv::Vec3b kOrange(30, 140, 230);  // BGR; Cr 80, Cg -14, Cb -124: inside the thesis box
inline const cv::Vec3b kLeaf(40, 120, 60);     // BGR; Cr -32: outside
inline const cv::Vec3b kSky(200, 190, 180);

inline cv::Mat3b background(int width, int height) { return cv::Mat3b(height, width, kLeaf); }

inline void render_sphere(cv::Mat3b& img, const geometry::CameraModel& cam, const Eigen::Vector3d& centre,
                          double radius, cv::Vec3b colour = kOrange) {
  const double c2 = centre.squaredNorm() - radius * radius;
  // Only pixels near the projected silhouette can be hit.
  const Eigen::Vector2d c = cam.project(centre);
  const double reach = 1.3 * std::max(cam.fx, cam.fy) * radius / std::sqrt(c2) + 3;
  const int x0 = std::max(0, static_cast<int>(c.x() - reach)),
            x1 = std::min(img.cols, static_cast<int>(c.x() + reach) + 1);
  const int y0 = std::max(0, static_cast<int>(c.y() - reach)),
            y1 = std::min(img.rows, static_cast<int>(c.y() + reach) + 1);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const Eigen::Vector2d m = cam.undistort_to_normalized({x, y});
      const Eigen::Vector3d d = Eigen::Vector3d(m.x(), m.y(), 1).normalized();
      const double b = d.dot(centre);
      if (b > 0 && b * b - c2 >= 0) img(y, x) = colour;
    }
}

inline void draw_disc(cv::Mat3b& img, double cx, double cy, double r, cv::Vec3b colour = kOrange) {
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) img(y, x) = colour;
}

// Fraction of the disc's pixels that carry `colour` (after occluders are drawn).
inline double visible_share(const cv::Mat3b& img, double cx, double cy, double r, cv::Vec3b colour = kOrange) {
  int in = 0, seen = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) {
        ++in;
        seen += img(y, x) == colour;
      }
  return in ? static_cast<double>(seen) / in : 0.0;
}

}  // namespace harvest::vision::test
