// Board views for calibration: finding a ChArUco board in a frame, and the
// choice of which frames to keep (sharp, showing enough of the board, not a
// repeat of a view already kept).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calib/board.hpp"

namespace harvest::calib {

// One frame's ChArUco corners. Corners are in the frame's own pixels. When
// `mirrored`, the board was found only in the left-right flipped frame: the
// camera's frame is improper (the thesis's fixed camera), and the solvers
// work in the flipped image (see mirror_model()).
struct BoardView {
  int64_t utime = 0;  // frame header utime (when it was sensed)
  cv::Size image_size;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;  // ChArUco corner ids, one per corner
  bool mirrored = false;
  double sharpness = 0.0;                      // variance of the Laplacian over the board's bounding box
  std::optional<Eigen::Isometry3d> tool_pose;  // tool in the base frame at utime (arm-moved procedures)
};

// Markers, interpolated ChArUco corners (cv::aruco::interpolateCornersCharuco)
// and sub-pixel refinement on a grey image. If nothing is found and
// `try_mirrored`, the flipped image is searched too. Empty ids: no board.
BoardView detect_board(const cv::Mat& gray, const cv::Ptr<cv::aruco::CharucoBoard>& board, bool try_mirrored);

// Variance of the Laplacian over the bounding box of `corners` (a blurred
// frame has weak second derivatives at the squares' edges).
double sharpness(const cv::Mat& gray, const std::vector<cv::Point2f>& corners);

// The corner's pixel in the image the board looks proper in (x flipped when mirrored).
cv::Point2f proper_pixel(const BoardView& v, const cv::Point2f& p);

enum class Verdict { kAccepted, kNoBoard, kTooFewCorners, kBlurred, kDuplicate, kNoPose, kMoving, kHandedness };
const char* verdict_name(Verdict v);

struct CollectorOptions {
  int min_corners = 8;  // a view must show this many corners
  // Variance of the Laplacian [grey level^2]; a view below is blurred. Sharp
  // simulated views of the 40 mm board at 0.4-0.7 m measure 2600-12600; a
  // Gaussian blur of sigma 0.9 px brings one of 4500 to 670, 1.1 px to 430.
  double min_sharpness = 500;
  // Views without a tool pose: a repeat when it shares 3/4 of its corners with
  // an accepted view and they moved less than this on average [px].
  double duplicate_px = 6.0;
  // With tool poses: a repeat when the tool is within both of an accepted view's pose.
  double duplicate_m = 0.005, duplicate_rad = 2.0 * M_PI / 180.0;
  bool need_pose = false;  // the arm-moved procedures
  int max_views = 0;       // stop accepting after this many (0: no limit)
};

class ViewCollector {
 public:
  explicit ViewCollector(CollectorOptions options) : options_(options) {}
  // Keeps the view or says why not.
  Verdict offer(BoardView view);
  // Counts a frame refused before it became a view (kMoving, kNoPose).
  void refuse(Verdict v) { ++counts_[v]; }
  const std::vector<BoardView>& views() const { return views_; }
  const std::map<Verdict, int>& counts() const { return counts_; }
  int frames() const;
  // "24 frames: 12 accepted, 3 blurred, 9 duplicate"
  std::string summary() const;
  // With tool poses: whether an accepted view was taken from within the
  // duplicate distance of `tool_pose` (checked before a frame is searched).
  bool repeats_pose(const Eigen::Isometry3d& tool_pose) const;
  bool full() const { return options_.max_views > 0 && static_cast<int>(views_.size()) >= options_.max_views; }

 private:
  bool duplicate(const BoardView& v) const;
  CollectorOptions options_;
  std::vector<BoardView> views_;
  std::map<Verdict, int> counts_;
};

}  // namespace harvest::calib
