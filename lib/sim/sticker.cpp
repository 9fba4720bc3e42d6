#include "sim/sticker.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sim/plane_patch.hpp"
#include "sim/splitmix.hpp"

namespace harvest::sim {
namespace {

constexpr int kTexels = 128;
constexpr double kLift = 0.0005;  // [m] above the peel, so the depth test puts it in front of the sphere

}  // namespace

cv::Mat3b sticker_print(int texels, uint64_t seed) {
  // Inks of the peel's hue at three lightnesses: corners by lightness, and
  // the detector's colour threshold still accepts most of the label.
  const cv::Vec3b inks[] = {{250, 196, 120}, {226, 112, 24}, {92, 38, 10}};
  cv::Mat3b img(texels, texels, inks[0]);
  uint64_t state = splitmix_hash(seed);
  auto next = [&state](int lo, int hi) { return lo + static_cast<int>(splitmix_next(state) % uint64_t(hi - lo)); };
  const int shapes = texels / 2;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point c(next(0, texels), next(0, texels));
    const int r = next(texels / 40 + 1, texels / 10 + 2);
    const cv::Vec3b& ink = inks[next(0, 3)];
    const cv::Scalar colour(ink[0], ink[1], ink[2]);
    if (next(0, 2) == 0)
      cv::circle(img, c, r, colour, cv::FILLED, cv::LINE_8);
    else
      cv::rectangle(img, cv::Rect(c.x - r, c.y - r / 2, 2 * r, r + 1), colour, cv::FILLED, cv::LINE_8);
  }
  cv::rectangle(img, cv::Rect(0, 0, texels, texels), cv::Scalar(inks[2][0], inks[2][1], inks[2][2]), 2);
  return img;
}

StickerPrimitive::StickerPrimitive(const Scene& scene, std::size_t fruit, double side, const Vec3& facing,
                                   uint64_t seed)
    : scene_(scene), fruit_(fruit), side_(side), texture_(sticker_print(kTexels, seed)) {
  const Vec3 stem = scene.fruit().at(fruit).stem_position;
  outward_ = (facing - stem).normalized();
  const Vec3 inward = -outward_;
  // v down the print along the base's "down" (+x) as far as the plane allows.
  Vec3 down = Vec3::UnitX() - Vec3::UnitX().dot(inward) * inward;
  if (down.norm() < 1e-6) down = Vec3::UnitY() - Vec3::UnitY().dot(inward) * inward;
  ey_ = down.normalized();
  ex_ = ey_.cross(inward);
}

Vec3 StickerPrimitive::centre() const {
  const Fruit& f = scene_.fruit()[fruit_];
  return f.position + (f.radius + kLift) * outward_;
}

void StickerPrimitive::draw(Renderer::Canvas& canvas, const Mat3& rotation, const Vec3& translation) const {
  const Fruit& f = scene_.fruit()[fruit_];
  if (f.state == FruitState::kPicked || f.state == FruitState::kKnocked) return;
  const double h = side_ / 2;
  const PlanePatch patch{
      rotation * centre() + translation, rotation * ex_, rotation * ey_, -(rotation * outward_), -h, h, -h, h, 4, 3};
  const double per_texel = side_ / kTexels;
  draw_plane_patch(canvas, patch, [&](double u, double v, bool front) {
    if (!front) return Vec3(200, 200, 200);  // the backing paper (inside the fruit: never seen)
    const int col = std::clamp(static_cast<int>((u + h) / per_texel), 0, kTexels - 1);
    const int row = std::clamp(static_cast<int>((v + h) / per_texel), 0, kTexels - 1);
    const cv::Vec3b& t = texture_(row, col);
    return Vec3(t[0], t[1], t[2]);
  });
}

}  // namespace harvest::sim
