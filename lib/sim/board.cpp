#include "sim/board.hpp"

#include <cmath>
#include <stdexcept>

namespace harvest::sim {
namespace {

constexpr int kTexels = 120;  // per square: marker bits land on whole texels for the usual ratios
// Samples per pixel, on an n-rooks pattern (each in its own sixteenth of the
// pixel's width and of its height): an edge in any direction is placed to
// 1/16 px, where a 4 x 4 grid of the same cost quantises axis-aligned edges to
// 1/4 px and biased the detected corners by 0.2 px.
constexpr int kSub = 16;
constexpr int kStride = 5;  // coprime with kSub: sample k sits at column k, row k * kStride mod kSub
constexpr double kWhite = 235.0, kBlack = 20.0, kBack = 120.0;

}  // namespace

BoardPrimitive::BoardPrimitive(const BoardSpec& spec, const Placement& pose)
    : spec_(spec),
      pose_(pose),
      board_(make_board(spec)),
      width_m_(spec.squares_x * spec.square_m),
      height_m_(spec.squares_y * spec.square_m) {
  board_->draw(cv::Size(spec.squares_x * kTexels, spec.squares_y * kTexels), texture_, 0, 1);
}

float BoardPrimitive::ink(double u, double v) const {
  if (u < 0.0 || v < 0.0 || u >= width_m_ || v >= height_m_) return 1.0f;  // the white margin
  // OpenCV 4.6's board frame has y down the printed image (row 0 at y = 0).
  const double per_texel = spec_.square_m / kTexels;
  const int col = std::min(texture_.cols - 1, static_cast<int>(u / per_texel));
  const int row = std::min(texture_.rows - 1, static_cast<int>(v / per_texel));
  return texture_.at<uint8_t>(row, col) > 127 ? 1.0f : 0.0f;
}

void BoardPrimitive::draw(Renderer::Canvas& canvas, const Mat3& rotation, const Vec3& translation) const {
  // Board frame in the camera frame.
  const Mat3 r = rotation * pose_.rotation;
  const Vec3 o = rotation * pose_.position + translation;
  const Eigen::Vector3d ex = r.col(0), ey = r.col(1), n = r.col(2);
  const double m = spec_.margin_m;
  // Plate corners -> normalised box (only if the whole plate is in front of the lens).
  double ax = 1e30, bx = -1e30, ay = 1e30, by = -1e30;
  for (const double u : {-m, width_m_ + m})
    for (const double v : {-m, height_m_ + m}) {
      const Vec3 p = o + u * ex + v * ey;
      if (p.z() <= 0.01) return;
      ax = std::min(ax, p.x() / p.z());
      bx = std::max(bx, p.x() / p.z());
      ay = std::min(ay, p.y() / p.z());
      by = std::max(by, p.y() / p.z());
    }
  const Renderer::PixelBox b =
      canvas.pixels(static_cast<float>(ax), static_cast<float>(bx), static_cast<float>(ay), static_cast<float>(by));
  const double nc = n.dot(o);
  const bool front = nc > 0.0;  // the camera is on the printed side (-z)
  const Eigen::Vector3f normal = (front ? n : -n).cast<float>();
  const int w = canvas.width(), h = canvas.height();
  for (int y = b.y0; y <= b.y1; ++y) {
    for (int x = b.x0; x <= b.x1; ++x) {
      const int i = y * w + x;
      const Eigen::Vector3d d = canvas.ray(i).cast<double>();
      // Sub-pixel rays from the neighbours' (the ray field is smooth).
      const int ix = x + 1 < w ? i + 1 : i - 1, iy = y + 1 < h ? i + w : i - w;
      const Eigen::Vector3d dx = (canvas.ray(ix).cast<double>() - d) * (x + 1 < w ? 1.0 : -1.0);
      const Eigen::Vector3d dy = (canvas.ray(iy).cast<double>() - d) * (y + 1 < h ? 1.0 : -1.0);
      const double nd = n.dot(d);
      if (std::abs(nd) < 1e-9) continue;
      const double depth = nc / nd;
      const Vec3 q = depth * d - o;
      const double u = q.dot(ex), v = q.dot(ey);
      if (u < -m || v < -m || u > width_m_ + m || v > height_m_ + m) continue;
      double shade = kBack;
      if (front) {
        float sum = 0.0f;
        for (int k = 0; k < kSub; ++k) {
          const int sy = (k * kStride) % kSub;
          const Eigen::Vector3d ds = d + ((k + 0.5) / kSub - 0.5) * dx + ((sy + 0.5) / kSub - 0.5) * dy;
          const Vec3 qs = (nc / n.dot(ds)) * ds - o;
          sum += ink(qs.dot(ex), qs.dot(ey));
        }
        shade = kBlack + (kWhite - kBlack) * sum / kSub;
      }
      canvas.put(i, static_cast<float>(depth), Vec3(shade, shade, shade), normal);
    }
  }
}

}  // namespace harvest::sim
