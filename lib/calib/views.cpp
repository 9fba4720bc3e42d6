#include "calib/views.hpp"

#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace harvest::calib {
namespace {

BoardView detect_once(const cv::Mat& gray, const cv::Ptr<cv::aruco::CharucoBoard>& board) {
  BoardView v;
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, board->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) return v;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, v.corners, v.ids);
  if (!v.corners.empty())
    cv::cornerSubPix(gray, v.corners, cv::Size(3, 3), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  return v;
}

}  // namespace

BoardView detect_board(const cv::Mat& gray, const cv::Ptr<cv::aruco::CharucoBoard>& board, bool try_mirrored) {
  CV_Assert(gray.type() == CV_8UC1);
  BoardView v = detect_once(gray, board);
  if (v.ids.empty() && try_mirrored) {
    cv::Mat flipped;
    cv::flip(gray, flipped, 1);
    v = detect_once(flipped, board);
    v.mirrored = !v.ids.empty();
    for (auto& c : v.corners) c.x = static_cast<float>(gray.cols - 1) - c.x;  // pixel centres at integers
  }
  v.image_size = gray.size();
  if (!v.ids.empty()) v.sharpness = sharpness(gray, v.corners);
  return v;
}

double sharpness(const cv::Mat& gray, const std::vector<cv::Point2f>& corners) {
  if (corners.empty()) return 0.0;
  const cv::Rect box = cv::boundingRect(corners) & cv::Rect(0, 0, gray.cols, gray.rows);
  if (box.width < 3 || box.height < 3) return 0.0;
  cv::Mat lap;
  cv::Laplacian(gray(box), lap, CV_64F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(lap, mean, stddev);
  return stddev[0] * stddev[0];
}

cv::Point2f proper_pixel(const BoardView& v, const cv::Point2f& p) {
  return v.mirrored ? cv::Point2f(static_cast<float>(v.image_size.width - 1) - p.x, p.y) : p;
}

const char* verdict_name(Verdict v) {
  switch (v) {
    case Verdict::kAccepted:
      return "accepted";
    case Verdict::kNoBoard:
      return "no board";
    case Verdict::kTooFewCorners:
      return "too few corners";
    case Verdict::kBlurred:
      return "blurred";
    case Verdict::kDuplicate:
      return "duplicate";
    case Verdict::kNoPose:
      return "no arm pose";
    case Verdict::kMoving:
      return "arm moving";
    case Verdict::kHandedness:
      return "other handedness";
  }
  return "?";
}

Verdict ViewCollector::offer(BoardView view) {
  const Verdict v = [&] {
    if (full()) return Verdict::kDuplicate;
    if (view.ids.empty()) return Verdict::kNoBoard;
    if (static_cast<int>(view.ids.size()) < options_.min_corners) return Verdict::kTooFewCorners;
    if (view.sharpness < options_.min_sharpness) return Verdict::kBlurred;
    if (options_.need_pose && !view.tool_pose) return Verdict::kNoPose;
    // One camera is either proper or not: a view of the other kind is a misdetection.
    if (!views_.empty() && view.mirrored != views_.front().mirrored) return Verdict::kHandedness;
    if (duplicate(view)) return Verdict::kDuplicate;
    return Verdict::kAccepted;
  }();
  ++counts_[v];
  if (v == Verdict::kAccepted) views_.push_back(std::move(view));
  return v;
}

bool ViewCollector::repeats_pose(const Eigen::Isometry3d& tool_pose) const {
  for (const BoardView& a : views_) {
    if (!a.tool_pose) continue;
    const Eigen::Isometry3d d = a.tool_pose->inverse() * tool_pose;
    if (d.translation().norm() < options_.duplicate_m && Eigen::AngleAxisd(d.linear()).angle() < options_.duplicate_rad)
      return true;
  }
  return false;
}

bool ViewCollector::duplicate(const BoardView& v) const {
  if (options_.need_pose) return repeats_pose(*v.tool_pose);
  for (const BoardView& a : views_) {
    std::map<int, cv::Point2f> at;
    for (std::size_t k = 0; k < a.ids.size(); ++k) at[a.ids[k]] = a.corners[k];
    int common = 0;
    double shift = 0.0;
    for (std::size_t k = 0; k < v.ids.size(); ++k) {
      const auto it = at.find(v.ids[k]);
      if (it == at.end()) continue;
      ++common;
      shift += cv::norm(it->second - v.corners[k]);
    }
    if (4 * common >= 3 * static_cast<int>(v.ids.size()) && shift < options_.duplicate_px * common) return true;
  }
  return false;
}

int ViewCollector::frames() const {
  int n = 0;
  for (const auto& [v, c] : counts_) n += c;
  return n;
}

std::string ViewCollector::summary() const {
  std::ostringstream s;
  s << frames() << " frames: " << views_.size() << " accepted";
  for (const auto& [v, c] : counts_)
    if (v != Verdict::kAccepted) s << ", " << c << " " << verdict_name(v);
  return s.str();
}

}  // namespace harvest::calib
