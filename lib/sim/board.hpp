// A ChArUco calibration board drawn by the renderer (issue 20): the layout is
// OpenCV's own (cv::aruco::CharucoBoard), so the corners a detector finds are
// the board's object points, and their true image positions are the camera
// model's projection of those points (tests/unit/sim/board_test.cpp).
#pragma once

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/core.hpp>

#include "calib/board.hpp"
#include "sim/renderer.hpp"
#include "sim/scenario.hpp"

namespace harvest::sim {

using calib::board_dictionaries;
using calib::make_board;

// The board on its plate; `pose` takes board-frame points to the base frame.
// The board frame is OpenCV 4.6's: origin at the top-left corner of the
// squares as printed, x to the right, y down the printed image, z into the
// board (the printed face looks along -z; the back is drawn plain grey).
class BoardPrimitive : public Renderer::Primitive {
 public:
  BoardPrimitive(const BoardSpec& spec, const Placement& pose);
  void set_pose(const Placement& pose) { pose_ = pose; }
  const Placement& pose() const { return pose_; }
  const BoardSpec& spec() const { return spec_; }
  const cv::Ptr<cv::aruco::CharucoBoard>& board() const { return board_; }

  void draw(Renderer::Canvas& canvas, const Mat3& rotation, const Vec3& translation) const override;

 private:
  // Printed reflectance at board point (u, v) [m]: 1 white, 0 black.
  float ink(double u, double v) const;

  BoardSpec spec_;
  Placement pose_;
  cv::Ptr<cv::aruco::CharucoBoard> board_;
  cv::Mat texture_;  // the board as OpenCV prints it, kTexels per square
  double width_m_, height_m_;
};

}  // namespace harvest::sim
