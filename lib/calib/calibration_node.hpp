// The replayable half of harvest-calibrate: collects board views from an
// image_t channel (and, for the arm-moved procedures, the tool pose from
// ROBOT_STATE at each frame's capture time). Live or over a log, the same
// messages in the same order give the same views.
#pragma once

#include <deque>
#include <functional>
#include <opencv2/core.hpp>
#include <string>

#include "calib/views.hpp"
#include "geometry/pose_history.hpp"
#include "harvest/image_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "runtime/node.hpp"

namespace harvest::calib {

struct CalibrationNodeConfig {
  std::string image_channel = "CAMERA_HAND";
  std::string robot_state_channel;  // empty: no arm poses (intrinsics)
  BoardSpec board;
  CollectorOptions collect;
  bool try_mirrored = true;  // also search the flipped frame (an improper camera frame)
  // Robot states must bracket a frame this closely for its pose to be interpolated.
  int64_t max_pose_gap_us = 50'000;
  // The arm counts as at rest when every ROBOT_STATE from settle_us before a
  // frame to max_pose_gap_us / 2 after it has the tool slower than these.
  int64_t settle_us = 200'000;
  double rest_speed_m_s = 0.002, rest_rate_rad_s = 0.01;
};

class CalibrationNode : public rt::Node {
 public:
  explicit CalibrationNode(CalibrationNodeConfig config);

  // Decides the frames still waiting for a later ROBOT_STATE (end of input).
  void finish();
  const ViewCollector& collector() const { return collector_; }
  const cv::Ptr<cv::aruco::CharucoBoard>& board() const { return board_; }
  // utime of the last frame received (0: none): the date of a replayed calibration.
  int64_t last_frame_utime() const { return last_frame_utime_; }
  // The joints on the last ROBOT_STATE (empty: none yet): where the arm is, for planning its moves.
  const Eigen::VectorXd& last_joints() const { return last_joints_; }
  // Called for every frame decided (progress output).
  std::function<void(const BoardView&, Verdict)> on_view;

 protected:
  void on_attach() override;

 private:
  struct Frame {
    int64_t utime;
    cv::Mat gray;
    cv::Rect2d roi;   // the sensor region the frame shows (sensor pixels)
    cv::Size sensor;  // the whole sensor
  };
  void on_image(const image_t& msg);
  void on_state(const robot_state_t& msg);
  void decide(Frame frame);
  void offer(BoardView view);

  CalibrationNodeConfig config_;
  cv::Ptr<cv::aruco::CharucoBoard> board_;
  ViewCollector collector_;
  geometry::PoseHistory poses_{4096};
  struct Motion {
    int64_t utime;
    bool at_rest;
  };
  std::deque<Motion> motion_;
  int64_t last_state_utime_ = -1;
  Eigen::VectorXd last_joints_;
  std::deque<Frame> pending_;
  int64_t last_frame_utime_ = 0;
};

}  // namespace harvest::calib
