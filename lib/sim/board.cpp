#include "sim/board.hpp"

#include <cmath>
#include <stdexcept>

#include "sim/plane_patch.hpp"

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
  const double m = spec_.margin_m;
  const PlanePatch patch{rotation * pose_.position + translation,
                         r.col(0),
                         r.col(1),
                         r.col(2),
                         -m,
                         width_m_ + m,
                         -m,
                         height_m_ + m,
                         kSub,
                         kStride};
  draw_plane_patch(canvas, patch, [this](double u, double v, bool front) {
    const double shade = front ? kBlack + (kWhite - kBlack) * ink(u, v) : kBack;
    return Vec3(shade, shade, shade);
  });
}

}  // namespace harvest::sim
