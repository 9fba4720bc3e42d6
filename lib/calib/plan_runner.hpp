// Drives the arm through a calibration plan (harvest-calibrate plan --run):
// one pose goal after the other through the robot link, signed as the
// controller the link obeys, each resent while it is being reached; at each
// pose the arm is stopped and rests `dwell_s` (the link IDLE, the tool
// still) so that the calibration finds frames taken at rest. The robot link validates and limits every goal as it does
// the controller's (reach, workspace, speed); this node only sequences them, and stops the arm and gives up on a fault,
// an emergency stop, a stale or missing ROBOT_STATE, or when the operator stops it.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "harvest/robot_state_t.hpp"
#include "runtime/node.hpp"
#include "security/auth.hpp"

namespace harvest::calib {

struct PlanRunConfig {
  std::vector<Eigen::Isometry3d> poses;  // tool poses, base frame
  double dwell_s = 1.0;                  // at rest at each pose
  // A pose counts as reached within these (the link's straight-path dry run
  // may end 0.01 rad from a goal); the arm is then stopped and must rest,
  // its mode IDLE, for dwell_s.
  double position_tolerance_m = 0.005, rotation_tolerance_rad = 0.03;
  double rest_speed_m_s = 0.002, rest_rate_rad_s = 0.01;  // and the tool this still
  double pose_timeout_s = 30.0;                           // a pose not reached by then is skipped (refused or blocked)
  double state_timeout_s = 0.5;                           // ROBOT_STATE older than this stops the run
  double max_linear_speed = 0.1;                          // [m/s] goal speeds (the link's own limits still apply)
  double max_angular_speed = 0.3;                         // [rad/s]
  double resend_period_s = 0.1;                           // a goal is resent this often (it is obeyed only while fresh)
  double validity_s = 0.3;
};

class PlanRunner final : public rt::Node {
 public:
  enum class Outcome { kRunning, kDone, kAborted };
  PlanRunner(PlanRunConfig config, security::Key key, std::string sender);

  Outcome outcome() const { return outcome_; }
  const std::string& why() const { return why_; }  // kAborted: the reason
  int reached() const { return reached_; }
  const std::vector<int>& skipped() const { return skipped_; }  // pose indices
  // Progress lines ("pose 3/12 reached after 4.1 s"), for the terminal.
  std::function<void(const std::string&)> on_progress;

  // The operator's stop (Ctrl-C): the arm is stopped and the run ends.
  void begin_shutdown() override;
  bool shutdown_complete() const override { return stopped_sent_; }

 protected:
  void on_attach() override;

 private:
  void tick();
  void send(int8_t type);  // a signed command: the current pose goal, or a stop
  void send_goal();
  void send_stop();
  void abort(const std::string& why);
  void finish();
  bool at_goal(const robot_state_t& s) const;
  bool still(const robot_state_t& s) const;
  // The link's reason when it refused the current goal (its state text names the command's seq).
  std::optional<std::string> refusal(const robot_state_t& s) const;
  void say(const std::string& line);

  PlanRunConfig config_;
  security::Signer signer_;
  std::optional<robot_state_t> state_;
  rt::Micros state_heard_ = 0;
  std::size_t index_ = 0;
  rt::Micros pose_started_ = 0, resting_since_ = -1, last_sent_ = -1, started_ = -1;
  int64_t goal_id_ = 0;
  int64_t goal_first_seq_ = -1;  // header.seq of the current goal's first send
  int reached_ = 0;
  std::vector<int> skipped_;
  Outcome outcome_ = Outcome::kRunning;
  std::string why_;
  bool stopped_sent_ = false;
  bool settling_ = false;  // arrived at the pose, stopped, waiting out the dwell at rest
};

}  // namespace harvest::calib
