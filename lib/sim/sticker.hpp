// A printed sticker on a fruit (teach by zooming, thesis sections 5.7, 7.2:
// natural peel gives no features to match, a textured label does). A square
// tangent to the peel, facing outwards toward a chosen point (the fixed
// camera), following the fruit as it sways or is carried; its print is
// random shapes in three inks of the peel's hue (a colour threshold still
// sees an orange), rich in corners, and the same for the same seed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

#include "sim/renderer.hpp"
#include "sim/scene.hpp"

namespace harvest::sim {

class StickerPrimitive : public Renderer::Primitive {
 public:
  // The sticker on scene.fruit()[fruit], `side` [m] square, its centre on the
  // ray from the fruit's stem position toward `facing` (base frame).
  StickerPrimitive(const Scene& scene, std::size_t fruit, double side, const Vec3& facing, uint64_t seed);

  void draw(Renderer::Canvas& canvas, const Mat3& rotation, const Vec3& translation) const override;

  // Where it is now (base frame): its centre on the peel and its outward normal.
  Vec3 centre() const;
  const Vec3& normal() const { return outward_; }
  const cv::Mat3b& texture() const { return texture_; }  // RGB, row = v (down the print)

 private:
  const Scene& scene_;
  std::size_t fruit_;
  double side_;
  Vec3 outward_, ex_, ey_;  // ex x ey = -outward: seen from outside, u runs right and v down the print
  cv::Mat3b texture_;
};

// The print of a sticker: `texels` square, RGB.
cv::Mat3b sticker_print(int texels, uint64_t seed);

}  // namespace harvest::sim
