#include "calib/calibration_node.hpp"

#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "geometry/pose_msg.hpp"

namespace harvest::calib {

namespace {
CollectorOptions with_pose_need(CollectorOptions o, bool need_pose) {
  o.need_pose = need_pose;
  return o;
}
}  // namespace

CalibrationNode::CalibrationNode(CalibrationNodeConfig config)
    : rt::Node("calibrate"),
      config_(std::move(config)),
      board_(make_board(config_.board)),
      collector_(with_pose_need(config_.collect, !config_.robot_state_channel.empty())) {}

void CalibrationNode::on_attach() {
  subscribe<image_t>(config_.image_channel, [this](const image_t& m) { on_image(m); });
  if (!config_.robot_state_channel.empty())
    subscribe<robot_state_t>(config_.robot_state_channel, [this](const robot_state_t& m) { on_state(m); });
}

void CalibrationNode::on_image(const image_t& msg) {
  if (collector_.full()) return;
  const camera::DecodedImage img = camera::decode_image(msg);
  if (!img.ok()) {
    count("bad_frames");
    return;
  }
  // Views are kept in sensor pixels, the pixels every calibration file and
  // process uses (a camera may publish its frames binned, as the simulator's do).
  Frame f{msg.header.utime,
          {},
          camera::image_roi(msg),
          msg.sensor_width > 0 ? cv::Size(msg.sensor_width, msg.sensor_height) : cv::Size(msg.width, msg.height)};
  cv::cvtColor(img.bgr, f.gray, cv::COLOR_BGR2GRAY);
  last_frame_utime_ = f.utime;
  if (config_.robot_state_channel.empty()) {
    decide(std::move(f));
    return;
  }
  // Its pose and rest need the robot states after it: decided in on_state.
  pending_.push_back(std::move(f));
}

void CalibrationNode::on_state(const robot_state_t& msg) {
  const int64_t t = msg.header.utime;
  poses_.add(t, geometry::to_isometry(msg.tool_pose));
  if (t >= last_state_utime_)
    last_joints_ = Eigen::Map<const Eigen::VectorXd>(msg.joint_position.data(), msg.num_joints);
  const auto& v = msg.tool_twist;
  const double speed = Eigen::Vector3d(v.linear[0], v.linear[1], v.linear[2]).norm();
  const double rate = Eigen::Vector3d(v.angular[0], v.angular[1], v.angular[2]).norm();
  motion_.push_back(
      {t, speed < config_.rest_speed_m_s && rate < config_.rest_rate_rad_s && msg.mode != robot_state_t::MODE_MOVING});
  while (motion_.size() > 4096) motion_.pop_front();
  last_state_utime_ = std::max(last_state_utime_, t);
  // A frame is decided once the states up to half a gap after it are in.
  while (!pending_.empty() && pending_.front().utime + config_.max_pose_gap_us / 2 <= last_state_utime_) {
    decide(std::move(pending_.front()));
    pending_.pop_front();
  }
}

void CalibrationNode::finish() {
  while (!pending_.empty()) {
    decide(std::move(pending_.front()));
    pending_.pop_front();
  }
}

void CalibrationNode::decide(Frame frame) {
  if (collector_.full()) return;
  std::optional<Eigen::Isometry3d> pose;
  if (!config_.robot_state_channel.empty()) {
    pose = poses_.at(frame.utime, config_.max_pose_gap_us);
    if (!pose) {
      collector_.refuse(Verdict::kNoPose);
      count("no_pose");
      return;
    }
    bool seen = false, moving = false;
    for (const Motion& m : motion_)
      if (m.utime >= frame.utime - config_.settle_us && m.utime <= frame.utime + config_.max_pose_gap_us / 2) {
        seen = true;
        moving = moving || !m.at_rest;
      }
    if (moving || !seen) {
      collector_.refuse(Verdict::kMoving);
      count("moving");
      return;
    }
    // The arm rests at each pose for many frames: only the first is searched.
    if (collector_.repeats_pose(*pose)) {
      collector_.refuse(Verdict::kDuplicate);
      count("duplicate");
      return;
    }
  }
  BoardView view = detect_board(frame.gray, board_, config_.try_mirrored);
  if (frame.roi.width != frame.gray.cols || frame.roi.height != frame.gray.rows || frame.roi.x != 0 ||
      frame.roi.y != 0) {
    const double sx = frame.roi.width / frame.gray.cols, sy = frame.roi.height / frame.gray.rows;
    for (cv::Point2f& c : view.corners)
      c = cv::Point2f(static_cast<float>((c.x + 0.5) * sx + frame.roi.x - 0.5),
                      static_cast<float>((c.y + 0.5) * sy + frame.roi.y - 0.5));
  }
  view.image_size = frame.sensor;
  view.utime = frame.utime;
  view.tool_pose = pose;
  offer(std::move(view));
}

void CalibrationNode::offer(BoardView view) {
  const Verdict v = collector_.offer(view);
  count(verdict_name(v));
  if (on_view) on_view(view, v);
}

}  // namespace harvest::calib
