// Software renderer of a Scene through one camera (the true intrinsics and
// distortion, via vision::CameraModel).
//
// Every pixel's viewing ray is precomputed once by undistorting the pixel
// (so distortion is exact, not approximated); each primitive (fruit sphere,
// branch bead, leaf blade) is then ray-cast only over the pixels of its
// bounding box, with a depth buffer for occlusion. Shading is Lambertian from
// the sun plus ambient, scaled by the exposure; sensor noise comes from a
// seeded table, so a frame depends only on the scene, pose and frame count.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "sim/scene.hpp"
#include "vision/camera_model.hpp"

namespace harvest::sim {

class Renderer {
 public:
  static constexpr int32_t kSky = -1;
  static constexpr int32_t kLeaf = -2;
  static constexpr int32_t kBranch = -3;

  Renderer(const vision::CameraModel& model, double noise_std, uint64_t seed);

  // Renders into an 8-bit BGR image (reused between calls). `pose` places the
  // camera optical frame in the base frame.
  const cv::Mat& render(const Scene& scene, const Placement& pose);

  // Per pixel of the last render: fruit index, or kSky / kLeaf / kBranch.
  const std::vector<int32_t>& ids() const { return ids_; }
  // Per fruit of the last render: pixels where it is the nearest surface, and
  // pixels its silhouette covers ignoring occluders (both inside the image).
  const std::vector<int>& visible_pixels() const { return visible_; }
  const std::vector<int>& silhouette_pixels() const { return silhouette_; }

  const vision::CameraModel& model() const { return model_; }

 private:
  struct PixelBox {
    int x0, y0, x1, y1;  // inclusive; empty when x0 > x1
  };
  // Pixels that may see a sphere of radius r at camera-frame centre c.
  PixelBox bounds(const Eigen::Vector3f& c, float r) const;
  // Pixels that may see a leaf blade (centre c, midrib u, across v, half sizes).
  PixelBox leaf_bounds(const Eigen::Vector3f& c, const Eigen::Vector3f& u, const Eigen::Vector3f& v, float hl,
                       float hw) const;
  // Pixels covering the normalised-coordinate box [ax, bx] x [ay, by].
  PixelBox normalized_box(float ax, float bx, float ay, float by) const;
  void put(int i, float depth, const Vec3& rgb, int32_t id);
  void draw_sphere(const Eigen::Vector3f& c, float r, const Vec3& albedo, int32_t id, const Eigen::Vector3f& sun,
                   const Lighting& light);
  void draw_leaf(const Leaf& leaf, const Mat3& rt, const Vec3& t, const Eigen::Vector3f& sun, const Lighting& light);

  vision::CameraModel model_;
  int w_, h_;
  std::vector<float> nx_, ny_;  // undistorted normalised ray per pixel (z = 1)
  float nx_min_, nx_max_, ny_min_, ny_max_;
  std::vector<float> depth_;
  std::vector<int32_t> ids_;
  std::vector<Vec3> rgb_;
  std::vector<int> visible_, silhouette_;
  std::vector<int16_t> noise_;  // N(0, noise_std) in 1/16 grey levels
  uint64_t noise_state_;
  cv::Mat image_;
};

}  // namespace harvest::sim
