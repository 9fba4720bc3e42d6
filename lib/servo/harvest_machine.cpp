#include "servo/harvest_machine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>

#include "servo/geometry.hpp"

namespace harvest::servo {

const char* state_name(State s) {
  switch (s) {
    case State::kIdle:
      return "IDLE";
    case State::kSelect:
      return "SELECT";
    case State::kOrient:
      return "ORIENT";
    case State::kAcquire:
      return "ACQUIRE";
    case State::kApproach:
      return "APPROACH";
    case State::kReacquire:
      return "REACQUIRE";
    case State::kIrApproach:
      return "IR_APPROACH";
    case State::kBackoff:
      return "BACKOFF";
    case State::kGrasp:
      return "GRASP";
    case State::kDetach:
      return "DETACH";
    case State::kDrop:
      return "DROP";
    case State::kRelease:
      return "RELEASE";
    case State::kRetreat:
      return "RETREAT";
    case State::kReturn:
      return "RETURN";
    case State::kHoming:
      return "HOMING";
    case State::kDone:
      return "DONE";
    case State::kFault:
      return "FAULT";
    case State::kEstop:
      return "ESTOP";
  }
  return "?";
}

namespace {

const char* outcome_name(int8_t o) {
  switch (o) {
    case fruit_outcome_t::PICKED:
      return "picked";
    case fruit_outcome_t::LOST:
      return "lost";
    case fruit_outcome_t::UNREACHABLE:
      return "unreachable";
    case fruit_outcome_t::FAILED_GRASP:
      return "failed grasp";
    case fruit_outcome_t::ABORTED:
      return "aborted";
  }
  return "?";
}

LimitsConfig limits_of(const ServoConfig& c) {
  return {c.max_linear_speed, c.max_angular_speed, c.max_linear_accel, c.max_angular_accel, c.validity_s};
}

Eigen::Vector3d vec(const double* p) { return {p[0], p[1], p[2]}; }

// A size-based hand estimate agrees with the rays' crossing within this share
// of the range (at least the floor): the hand depth's own error is about 10 %
// rms (the tree runs' depth-error table), a leaf-cut fruit's a factor of 1.5
// or more.
constexpr double kSizeAgreement = 0.3;
constexpr double kSizeAgreementFloor = 0.1;  // [m]

}  // namespace

HarvestMachine::HarvestMachine(ServoConfig config, std::unique_ptr<ApproachStrategy> approach)
    : cfg_(std::move(config)), approach_(std::move(approach)), limiter_(limits_of(cfg_), cfg_.workspace) {}

// ---------------------------------------------------------------- queries

bool HarvestMachine::running() const {
  switch (state_) {
    case State::kIdle:
    case State::kDone:
    case State::kFault:
    case State::kEstop:
      return false;
    default:
      return true;
  }
}

bool HarvestMachine::robot_fresh(rt::Micros now) const {
  return robot_ && now - robot_rx_ <= rt::from_seconds(cfg_.timeouts.robot_state);
}

Eigen::Isometry3d HarvestMachine::tool() const {
  return robot_ ? to_isometry(robot_->tool_pose) : Eigen::Isometry3d::Identity();
}
Eigen::Isometry3d HarvestMachine::camera() const {
  return robot_ ? to_isometry(robot_->camera_pose) : Eigen::Isometry3d::Identity();
}

std::optional<PixelMeasurement> HarvestMachine::fresh_pixel(rt::Micros now) const {
  if (pixel_ && now - pixel_rx_ <= rt::from_seconds(cfg_.timeouts.lost)) return pixel_;
  return std::nullopt;
}

std::optional<std::string> HarvestMachine::gripper_fault() const {
  if (!gripper_) return std::nullopt;
  if (gripper_->state == gripper_state_t::STATE_FAULT)
    return "gripper fault " + std::to_string(gripper_->fault_code) + ": " + gripper_->fault_text;
  if (gripper_->state == gripper_state_t::STATE_DISCONNECTED || !gripper_->connected) return "gripper disconnected";
  return std::nullopt;
}

harvest_status_t HarvestMachine::status() const {
  harvest_status_t s{};
  s.header.frame_id = "base";
  s.header.source_seq = robot_ ? robot_->header.seq : -1;
  s.header.utime = robot_ ? robot_->header.utime : 0;
  s.state = state_name(state_);
  s.paused = paused_;
  s.estop = estop_;
  s.current_fruit_id = current_fruit();
  s.picked = picked_;
  s.lost = lost_;
  s.unreachable = unreachable_;
  s.failed_grasp = failed_grasp_;
  s.remaining = 0;
  if (fixed_)
    for (const auto& t : fixed_->targets)
      if (!finished_.count(t.fruit_id) && t.fruit_id != current_fruit()) ++s.remaining;
  s.summary = summary();
  // The newest outcomes only, so the message stays small on a long run.
  constexpr std::size_t kMaxOutcomes = 50;
  const std::size_t first = outcomes_.size() > kMaxOutcomes ? outcomes_.size() - kMaxOutcomes : 0;
  s.outcomes.assign(outcomes_.begin() + static_cast<std::ptrdiff_t>(first), outcomes_.end());
  s.num_outcomes = static_cast<int32_t>(s.outcomes.size());
  return s;
}

std::string HarvestMachine::summary() const {
  std::ostringstream o;
  o << state_name(state_);
  if (paused_) o << " (paused)";
  if (estop_) o << " [E-STOP latched]";
  if (current_) o << " fruit " << current_->id;
  o << " | picked " << picked_ << ", lost " << lost_ << ", unreachable " << unreachable_ << ", failed grasp "
    << failed_grasp_ << ", aborted " << aborted_;
  if (!note_.empty()) o << " | " << note_;
  return o.str();
}

// ---------------------------------------------------------------- commands

robot_command_t HarvestMachine::command(int8_t type) const {
  robot_command_t c{};
  // A command is derived from the newest robot state it was computed from.
  c.header.utime = robot_ ? robot_->header.utime : 0;
  c.header.source_seq = robot_ ? robot_->header.seq : -1;
  c.header.frame_id = "base";
  c.type = type;
  c.validity_us = rt::from_seconds(cfg_.validity_s);
  c.pose_goal.orientation[0] = 1.0;
  c.num_joints = 0;
  c.max_linear_speed = cfg_.max_linear_speed;
  c.max_angular_speed = cfg_.max_angular_speed;
  c.goal_id = goal_id_;
  return c;
}

robot_command_t HarvestMachine::twist_command(const Twist& desired) {
  const Twist t = limiter_.apply(desired, tool().translation(), cfg_.tick_period_s);
  robot_command_t c = command(robot_command_t::TYPE_TWIST);
  c.twist = to_twist(t.linear, t.angular);
  return c;
}

robot_command_t HarvestMachine::goal_command() const {
  robot_command_t c = command(robot_command_t::TYPE_POSE_GOAL);
  c.pose_goal = to_pose(goal_);
  return c;
}

gripper_command_t HarvestMachine::gripper_command(int8_t action) const {
  gripper_command_t g{};
  g.header.utime = robot_ ? robot_->header.utime : 0;
  g.header.source_seq = -1;
  g.header.frame_id = "gripper";
  g.action = action;
  g.position = action == gripper_command_t::ACTION_OPEN ? 1.0f : 0.0f;
  g.force_n = 0.0f;
  return g;
}

// ---------------------------------------------------------------- transitions

namespace {
// States that command twists (the others send pose goals, STOP or nothing).
bool twist_state(State s) {
  return s == State::kAcquire || s == State::kApproach || s == State::kReacquire || s == State::kIrApproach ||
         s == State::kGrasp;
}
}  // namespace

void HarvestMachine::enter(State s, rt::Micros now, MachineOutput& out) {
  // From one twist state to another the twist keeps ramping within the
  // acceleration limit (no step to a new speed, no hard stop when the fruit
  // is lost); after a pose goal or a stop it ramps up from rest.
  if (!(twist_state(state_) && twist_state(s))) limiter_.reset();
  state_ = s;
  entered_at_ = now;
  out.status_changed = true;
  const Timeouts& t = cfg_.timeouts;
  double timeout = 0.0;
  switch (s) {
    case State::kSelect:
      timeout = t.select;
      break;
    case State::kOrient:
    case State::kBackoff:
    case State::kDetach:
    case State::kDrop:
    case State::kRetreat:
    case State::kReturn:
    case State::kHoming:
      timeout = t.motion;
      break;
    case State::kAcquire:
      timeout = t.acquire;
      break;
    case State::kApproach:
      timeout = t.approach;
      break;
    case State::kReacquire:
      timeout = t.reacquire;
      break;
    case State::kIrApproach:
      timeout = t.ir_approach;
      break;
    case State::kGrasp:
      timeout = t.grasp;
      break;
    case State::kRelease:
      timeout = t.release;
      break;
    case State::kIdle:
    case State::kDone:
      stop_pending_ = true;
      break;
    case State::kFault:
    case State::kEstop:
      break;
  }
  deadline_ = timeout > 0 ? now + rt::from_seconds(timeout) : 0;
}

Eigen::Isometry3d HarvestMachine::inside_workspace(const Eigen::Isometry3d& goal) const {
  // A goal outside the workspace is pulled back along the straight line from
  // the current position to the furthest point still inside.
  if (cfg_.workspace.contains(goal.translation())) return goal;
  const Eigen::Vector3d from = tool().translation();
  const Eigen::Vector3d to = goal.translation();
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 30; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cfg_.workspace.contains(from + mid * (to - from)) ? lo : hi) = mid;
  }
  Eigen::Isometry3d g = goal;
  g.translation() = from + lo * (to - from);
  return g;
}

void HarvestMachine::start_goal(const Eigen::Isometry3d& goal, State s, rt::Micros now, MachineOutput& out) {
  goal_ = inside_workspace(goal);
  ++goal_id_;
  goal_best_position_ = std::numeric_limits<double>::infinity();
  goal_best_rotation_ = std::numeric_limits<double>::infinity();
  goal_progress_at_ = now;
  enter(s, now, out);
  out.robot = goal_command();
}

bool HarvestMachine::goal_stalled(rt::Micros now) {
  // Progress is a step of at least 2 mm or 0.01 rad toward the goal: well
  // above encoder noise, well below what the slowest goal motion covers in a
  // stall period.
  constexpr double kPositionStep = 0.002, kRotationStep = 0.01;
  const Eigen::Isometry3d t = tool();
  const double position = (t.translation() - goal_.translation()).norm();
  const double rotation = rotation_distance(t.rotation(), goal_.rotation());
  bool progress = false;
  if (position < goal_best_position_ - kPositionStep) {  // always true against the initial infinity
    goal_best_position_ = position;
    progress = true;
  }
  if (rotation < goal_best_rotation_ - kRotationStep) {
    goal_best_rotation_ = rotation;
    progress = true;
  }
  if (progress) goal_progress_at_ = now;
  return now - goal_progress_at_ > rt::from_seconds(cfg_.timeouts.stall);
}

void HarvestMachine::motion_blocked(const std::string& why, rt::Micros now, MachineOutput& out) {
  switch (state_) {
    case State::kOrient:
      // The aim is a means to get the fruit into the hand image: an arm that
      // stopped short of it (a joint limit a few millimetres before the
      // viewpoint) with the fruit well inside the image acquires it from there.
      if (estimate_in_hand_view()) {
        note_ = "fruit " + std::to_string(current_->id) + ": the turn " + why + " short of its goal, the fruit in view";
        approach_from_ = tool().translation();
        enter(State::kAcquire, now, out);
        break;
      }
      // Aiming happens at home or at a viewpoint outside the canopy, so the
      // arm is still clear of it: the fruit is out of its reach from there;
      // others may not be.
      if (!current_->from_viewpoint && aim_from_viewpoint(current_->estimate)) {
        note_ = "fruit " + std::to_string(current_->id) + ": the arm could not turn to it (" + why +
                "), aiming from a viewpoint";
        current_->from_viewpoint = true;
        start_goal(cfg_.home_pose, State::kReturn, now,
                   out);  // back to home first: the viewpoint is reached from there
        break;
      }
      attempts_[current_->id] = cfg_.max_attempts_per_fruit;  // what the arm cannot reach now it never will
      fail_fruit(fruit_outcome_t::UNREACHABLE,
                 (current_->from_viewpoint ? "the arm could not reach a viewpoint of it ("
                                           : "the arm could not turn to it (") +
                     why + ")",
                 false, now, out);
      break;
    case State::kBackoff:
      // Backing off for a second IR attempt is blocked (a joint limit next to
      // the canopy): give this fruit up as for an IR that never triggered.
      fail_fruit(fruit_outcome_t::FAILED_GRASP, "IR sensor never triggered (back-off " + why + ")", true, now, out);
      break;
    case State::kRetreat:
      note_ = "retreat " + why + ", returning home directly";
      start_goal(cfg_.home_pose, State::kReturn, now, out);
      break;
    case State::kDetach:
      // The pull got part of the way (often far enough to detach): the drop
      // leaves along another path and finishes pulling it off (even when the
      // fruit is released at the detach otherwise), and the gripper state
      // says whether the fruit is still held.
      note_ = "detach " + why + ", going on to the drop";
      start_goal(cfg_.drop_pose, State::kDrop, now, out);
      break;
    default:
      fault("motion " + why + " in " + state_name(state_), now, out);
      break;
  }
}

bool HarvestMachine::estimate_in_hand_view() const {
  // Inside the middle of the image (a margin of a fifth of each side), so the
  // fruit, its estimate's error and the first centring motion stay in view.
  constexpr double kMargin = 0.2;
  const CameraIntrinsics& k = cfg_.hand_camera;
  Eigen::Vector2d px;
  return project_point(k, camera().inverse() * current_->estimate, px) && px.x() >= kMargin * k.width &&
         px.x() <= (1.0 - kMargin) * k.width && px.y() >= kMargin * k.height && px.y() <= (1.0 - kMargin) * k.height;
}

bool HarvestMachine::goal_reached() const {
  const Eigen::Isometry3d t = tool();
  return (t.translation() - goal_.translation()).norm() <= cfg_.position_tolerance &&
         rotation_distance(t.rotation(), goal_.rotation()) <= cfg_.orient_tolerance;
}

void HarvestMachine::record(int8_t outcome, int fruit_id, const Eigen::Vector3d& target, const std::string& detail,
                            rt::Micros since, rt::Micros now, MachineOutput& out) {
  fruit_outcome_t o{};
  o.fruit_id = fruit_id;
  o.outcome = outcome;
  o.cycle_time_s = rt::to_seconds(now - since);
  const Eigen::Vector3d p = tool().translation();
  for (int i = 0; i < 3; ++i) {
    o.target_base[i] = target[i];
    o.final_tool_position[i] = p[i];
  }
  o.detail = detail;
  outcomes_.push_back(o);
  switch (outcome) {
    case fruit_outcome_t::PICKED:
      ++picked_;
      break;
    case fruit_outcome_t::LOST:
      ++lost_;
      break;
    case fruit_outcome_t::UNREACHABLE:
      ++unreachable_;
      break;
    case fruit_outcome_t::FAILED_GRASP:
      ++failed_grasp_;
      break;
    default:
      ++aborted_;
      break;
  }
  // A picked fruit has left the tree, and with it its fixed-camera target:
  // an id still seen afterwards is a fruit still there (the camera-in-hand
  // followed a neighbour to the grasp, or the tracker passed the id on), so
  // it may be tried again. Any other fruit is given up for good once out of
  // attempts (a certain verdict, such as a line of sight out of reach or an
  // arm that cannot turn to it, uses them all up).
  if (outcome == fruit_outcome_t::PICKED) {
    attempts_.erase(fruit_id);
  } else if (attempts_[fruit_id] >= cfg_.max_attempts_per_fruit) {
    finished_.insert(fruit_id);
    const Eigen::Vector3d at = current_ && current_->id == fruit_id ? current_->selected_from : target;
    finished_at_[fruit_id] = at;
    const bool ours = current_ && current_->id == fruit_id;
    if (ours && current_->sight) finished_sight_[fruit_id] = current_->sight->direction;
    given_up_.push_back(at);
    if (ours && current_->sight) given_up_sights_.push_back(current_->sight->direction);
  }
  note_ = "fruit " + std::to_string(fruit_id) + " " + outcome_name(outcome) + (detail.empty() ? "" : ": " + detail);
  out.status_changed = true;
}

void HarvestMachine::fail_fruit(int8_t outcome, const std::string& detail, bool retreat, rt::Micros now,
                                MachineOutput& out) {
  if (current_) record(outcome, current_->id, current_->estimate, detail, current_->selected_at, now, out);
  current_.reset();
  pixel_.reset();
  hand_target_px_.reset();
  if (retreat) {
    start_goal(retreat_goal(), State::kRetreat, now, out);
  } else {
    start_goal(cfg_.home_pose, State::kReturn, now, out);
  }
  approach_from_.reset();
}

Eigen::Isometry3d HarvestMachine::back_along_axis(const std::optional<Eigen::Vector3d>& abreast_of,
                                                  double at_least) const {
  Eigen::Isometry3d g = tool();
  const Eigen::Vector3d axis = g.rotation().col(2);
  double back = at_least;
  if (abreast_of) back = std::max(back, (g.translation() - *abreast_of).dot(axis));
  g.translation() -= back * axis;
  return g;
}

void HarvestMachine::fault(const std::string& detail, rt::Micros now, MachineOutput& out) {
  if (current_)
    record(fruit_outcome_t::ABORTED, current_->id, current_->estimate, detail, current_->selected_at, now, out);
  current_.reset();
  paused_ = false;
  enter(State::kFault, now, out);
  note_ = "FAULT: " + detail;
  out.robot = stop_command();
  out.log = note_;
}

bool HarvestMachine::at_home() const {
  const Eigen::Isometry3d t = tool();
  return (t.translation() - cfg_.home_pose.translation()).norm() <= cfg_.position_tolerance &&
         rotation_distance(t.rotation(), cfg_.home_pose.rotation()) <= cfg_.orient_tolerance;
}

void HarvestMachine::begin_from_home(rt::Micros now, MachineOutput& out) {
  // Every fruit is selected and aimed at from the home pose (the view the
  // fixed camera's estimate is good for): a start anywhere else, e.g. after an
  // emergency stop or a fault next to the canopy, first backs out along the
  // tool axis and returns home (RETREAT -> RETURN -> SELECT).
  if (at_home()) {
    enter(State::kSelect, now, out);
    return;
  }
  if ((tool().translation() - cfg_.home_pose.translation()).norm() > cfg_.retreat_distance) {
    Eigen::Isometry3d g = tool();
    g.translation() -= cfg_.retreat_distance * g.rotation().col(2);
    start_goal(g, State::kRetreat, now, out);
  } else {
    start_goal(cfg_.home_pose, State::kReturn, now, out);
  }
}

bool HarvestMachine::pickable(const Eigen::Vector3d& p) const {
  // Every fruit is aimed at from home (eq. 6-19..6-22): a target beside or
  // behind the gripper there cannot be turned to and seen.
  const Eigen::Vector3d axis = cfg_.home_pose.linear().col(2);
  return cfg_.workspace.contains(p) && (p - cfg_.home_pose.translation()).dot(axis) >= cfg_.min_ahead_of_home;
}

std::optional<HarvestMachine::SightLine> HarvestMachine::sight_line(const targets_t& view, const target_t& t) const {
  if (!view.camera_known) return std::nullopt;  // a view from before the field existed
  SightLine line;
  line.origin = vec(view.camera_position_base);
  const Eigen::Vector3d d = vec(t.position_base) - line.origin;
  if (d.norm() < 1e-6) return std::nullopt;
  line.direction = d.normalized();
  // Scan in 5 mm steps out to 3 m (beyond any workspace): the pickable set
  // is a box cut by a shell and a half-space, so the first and the last
  // pickable step bound it along a straight line.
  constexpr double kStep = 0.005, kFar = 3.0;
  bool found = false;
  for (double s = 0.0; s <= kFar; s += kStep) {
    if (!pickable(line.at(s))) continue;
    if (!found) line.near = s;
    line.far = s;
    found = true;
  }
  if (!found) return std::nullopt;
  return line;
}

Eigen::Vector3d HarvestMachine::sight_aim(const SightLine& line, double s_start, const Eigen::Vector3d& from) const {
  // The hand camera's narrower half field of view, less ~4 deg for the
  // fruit's own size: the whole stretch stays in the image.
  const CameraIntrinsics& k = cfg_.hand_camera;
  const double half = std::min(std::atan2(k.u0, k.fx), std::atan2(k.v0, k.fy));
  const double span = 2.0 * std::max(0.05, half - 0.07);
  const double s_end = std::abs(s_start - line.near) < std::abs(s_start - line.far) ? line.far : line.near;
  auto dir = [&](double s) { return (line.at(s) - from).normalized(); };
  const Eigen::Vector3d u0 = dir(s_start);
  // Seen from a point, the direction to a point moving along a line turns
  // monotonically away from where it started: walk until the span is used up.
  constexpr int kSteps = 200;
  double s_last = s_start;
  for (int i = 1; i <= kSteps; ++i) {
    const double s = s_start + (s_end - s_start) * i / kSteps;
    if (std::acos(std::clamp(u0.dot(dir(s)), -1.0, 1.0)) > span) break;
    s_last = s;
  }
  const Eigen::Vector3d middle = (u0 + dir(s_last)).normalized();
  double best_s = s_start, best = -2.0;
  for (int i = 0; i <= kSteps; ++i) {
    const double s = s_start + (s_last - s_start) * i / kSteps;
    if (const double c = middle.dot(dir(s)); c > best) {
      best = c;
      best_s = s;
    }
  }
  return line.at(best_s);
}

void HarvestMachine::select(rt::Micros now, MachineOutput& out) {
  const targets_t& view = *fixed_;
  const target_t* best = nullptr;
  std::optional<Fruit> chosen;
  for (const auto& t : view.targets) {
    const Eigen::Vector3d p = vec(t.position_base);
    // The fixed camera's line of sight to it: a depth from the apparent size
    // may jump by decimetres from image to image, the direction does not.
    std::optional<Eigen::Vector3d> sight;
    if (view.camera_known && (p - vec(view.camera_position_base)).norm() > 1e-6)
      sight = (p - vec(view.camera_position_base)).normalized();
    auto along = [&](const Eigen::Vector3d& d) {
      return sight && std::acos(std::clamp(d.dot(*sight), -1.0, 1.0)) <= cfg_.same_sight_angle;
    };
    if (finished_.count(t.fruit_id)) {
      const auto at = finished_at_.find(t.fruit_id);
      const auto seen = finished_sight_.find(t.fruit_id);
      if (at == finished_at_.end() || (at->second - p).norm() <= cfg_.reused_id_distance ||
          (seen != finished_sight_.end() && along(seen->second)))
        continue;
      // Far from where this id was finished: another fruit under a reused id.
      finished_.erase(t.fruit_id);
      finished_at_.erase(t.fruit_id);
      finished_sight_.erase(t.fruit_id);
      attempts_.erase(t.fruit_id);
    }
    if (attempts_[t.fruit_id] >= cfg_.max_attempts_per_fruit) continue;
    if (std::any_of(given_up_.begin(), given_up_.end(),
                    [&](const Eigen::Vector3d& q) { return (q - p).norm() <= cfg_.same_fruit_distance; }) ||
        std::any_of(given_up_sights_.begin(), given_up_sights_.end(), along)) {
      finished_.insert(t.fruit_id);  // a fruit already given up, seen again under a new id
      finished_at_[t.fruit_id] = p;
      continue;
    }
    Fruit f{t.fruit_id, p, now, p, sight_line(view, t), false};
    if (t.diameter_m > 0) f.diameter = t.diameter_m;
    if (!pickable(p)) {
      // The fixed camera's depth comes from the fruit's apparent size, its
      // direction from the calibration: a piece of a fruit looks small and
      // far, fruit side by side look large and near. Aim at the part of the
      // line of sight where a fruit can be picked, nearest the estimate, and
      // let the camera-in-hand measure it (eq. 6-15); only a line of sight
      // that never gets there is unreachable.
      if (!f.sight) {
        attempts_[t.fruit_id] = cfg_.max_attempts_per_fruit;
        const char* why = view.camera_known            ? "out of reach along its whole line of sight"
                          : cfg_.workspace.contains(p) ? "not ahead of the gripper at home"
                                                       : "outside the reachable workspace";
        record(fruit_outcome_t::UNREACHABLE, t.fruit_id, p, why, now, now, out);
        continue;
      }
      const double s = std::clamp((p - f.sight->origin).dot(f.sight->direction), f.sight->near, f.sight->far);
      f.estimate = sight_aim(*f.sight, s, tool().translation());
      f.depth_doubtful = true;
    }
    // Fruit not tried yet first (a fruit that failed is tried again once its
    // neighbours are off the tree: fruit seen together come apart), and among
    // them those whose fixed-camera depth is plausible first.
    if (best == nullptr ||
        std::make_tuple(attempts_[t.fruit_id], f.depth_doubtful, t.cost, t.fruit_id) <
            std::make_tuple(attempts_[best->fruit_id], chosen->depth_doubtful, best->cost, best->fruit_id)) {
      best = &t;
      chosen = f;
    }
  }
  if (best == nullptr) {
    note_ = "no reachable fruit left";
    enter(State::kDone, now, out);
    return;
  }
  current_ = chosen;
  ++attempts_[best->fruit_id];
  approach_->reset();
  pixel_.reset();
  hand_target_px_.reset();
  if (current_->depth_doubtful)
    note_ = "fruit " + std::to_string(current_->id) + ": fixed-camera depth doubtful, aiming along its line of sight";
  orient(now, out);
}

void HarvestMachine::orient(rt::Micros now, MachineOutput& out) {
  const Eigen::Vector3d axis = tool().linear().col(2);
  const Eigen::Vector3d to = (current_->estimate - tool().translation()).normalized();
  if (std::acos(std::clamp(axis.dot(to), -1.0, 1.0)) > cfg_.max_aim_angle) current_->from_viewpoint = true;
  const auto view = current_->from_viewpoint ? aim_from_viewpoint(current_->estimate) : std::nullopt;
  if (!view) current_->from_viewpoint = false;
  start_goal(view ? *view : aim_in_place(current_->estimate), State::kOrient, now, out);
}

Eigen::Isometry3d HarvestMachine::aim_in_place(const Eigen::Vector3d& target) const {
  Eigen::Isometry3d goal = tool();
  goal.linear() = aim_rotation(tool(), target);
  return goal;
}

std::optional<Eigen::Isometry3d> HarvestMachine::aim_from_viewpoint(const Eigen::Vector3d& target) const {
  // Seen from the side, along the home axis turned a little toward it, so
  // the arm's posture stays near the home one and the approach still comes
  // from outside the canopy.
  if (cfg_.view_angle <= 0.0) return std::nullopt;
  const Eigen::Vector3d axis = cfg_.home_pose.linear().col(2);
  const Eigen::Vector3d to = (target - cfg_.home_pose.translation()).normalized();
  const Eigen::Vector3d normal = axis.cross(to);
  if (normal.norm() < 1e-6) return std::nullopt;  // straight ahead: nothing to gain
  const double turn = std::min(cfg_.view_angle, std::acos(std::clamp(axis.dot(to), -1.0, 1.0)));
  const Eigen::Vector3d view_axis = Eigen::AngleAxisd(turn, normal.normalized()) * axis;
  Eigen::Isometry3d from = cfg_.home_pose;
  from.translation() = target - cfg_.view_distance * view_axis;
  if (!cfg_.workspace.contains(from.translation())) return std::nullopt;
  from.linear() = aim_rotation(from, target);
  return from;
}

void HarvestMachine::on_timeout(rt::Micros now, MachineOutput& out) {
  switch (state_) {
    case State::kSelect:
      note_ = "no view from the fixed camera";
      enter(State::kDone, now, out);
      break;
    case State::kAcquire:
      fail_fruit(fruit_outcome_t::LOST, "not seen by the camera-in-hand", false, now, out);
      break;
    case State::kReacquire:
      fail_fruit(fruit_outcome_t::LOST, "lost from view, not re-acquired", true, now, out);
      break;
    case State::kApproach:
      fail_fruit(fruit_outcome_t::LOST, "approach timed out", true, now, out);
      break;
    case State::kIrApproach:
      // Same as running out of travel: back off and retry, or give up.
      if (ir_attempt_ < cfg_.ir_attempts) {
        // Back along the tool axis to abreast of where IR guidance began
        // (the straight line back to that point cuts sideways through
        // neighbouring fruit where the centring moved the tool).
        start_goal(back_along_axis(ir_start_, 0.0), State::kBackoff, now, out);
      } else {
        fail_fruit(fruit_outcome_t::FAILED_GRASP, "IR sensor never triggered", true, now, out);
      }
      break;
    case State::kGrasp:
      fault("gripper did not report holding or closed in time", now, out);
      break;
    case State::kRelease:
      fault("gripper did not report open in time", now, out);
      break;
    default:
      motion_blocked("did not complete", now, out);
      break;
  }
}

double HarvestMachine::ir_forward_speed(bool ir_sees_fruit) const {
  // Fast while far, then braking at a constant rate, so the arm reaches the
  // grasp range slowly: the stop overshoots by v^2 / 2a plus the travel
  // during one IR period. Before the IR sees the fruit, the hand
  // camera's estimate says how far it is (the IR range is from the palm, the
  // estimate to the fruit centre: both end at the grasp point within a few cm).
  // The IR range (palm to fruit surface) ends at the grasp range about 2 cm
  // before the estimate (tool point to fruit centre) ends at zero, so the
  // estimate is the longer of the two; it bounds the IR's: the sensor's
  // fold-back makes a fruit nearer than its peak read far, and the arm must
  // not speed up into it.
  const Eigen::Isometry3d t = tool();
  double to_go = (current_->estimate - t.translation()).dot(t.rotation().col(2));
  if (ir_sees_fruit) to_go = std::min(to_go, static_cast<double>(ir_->range_m) - cfg_.ir_grasp_range);
  // The speed from which braking at ir_braking_decel stops at the grasp
  // range: the shortest approach that never brakes harder than that.
  return std::clamp(std::sqrt(2.0 * cfg_.ir_braking_decel * std::max(0.0, to_go)), cfg_.ir_min_speed,
                    cfg_.ir_approach_speed);
}

// ---------------------------------------------------------------- inputs

MachineOutput HarvestMachine::on_targets(const targets_t& msg, rt::Micros now) {
  MachineOutput out;
  if (msg.source_camera == "fixed") {
    const bool first = !fixed_;
    fixed_ = msg;
    fixed_rx_ = now;
    out.status_changed = first;
    return out;
  }
  // The camera-in-hand re-estimate replaces the fixed camera's (eq. 6-15).
  // It is the target made from the very detection we follow (same image,
  // same pixel), whatever id the reconstructor matched it to in 3D: its
  // match against a fixed-camera estimate with a wrong depth would fail.
  if (!current_) return out;
  for (const auto& t : msg.targets) {
    if (t.fruit_id != current_->id) continue;
    hand_target_px_ = Eigen::Vector2d(t.u_px, t.v_px);  // the next image's prediction, see on_hand_fruit
    hand_target_rx_ = now;
  }
  // A fruit cut by the image border, or filling most of the image (near,
  // under IR guidance), has no apparent size to take a depth from: the
  // estimate stays the last one that had (eq. 6-15).
  if (!pixel_ || msg.header.utime != pixel_->utime || !pixel_whole_) return out;
  constexpr double kSamePixel = 0.5;  // [px] the reconstructor copies the detection's centroid
  for (const auto& t : msg.targets) {
    if ((Eigen::Vector2d(t.u_px, t.v_px) - Eigen::Vector2d(pixel_->u, pixel_->v)).norm() > kSamePixel) continue;
    const Eigen::Vector3d sized = vec(t.position_base);
    current_->depth_doubtful = false;
    current_->estimate = sized;
    current_->depth = Fruit::Depth::kSize;
    if (pixel_crossing_) {
      // The size is the better depth near the fruit (its error shrinks with
      // the distance, the crossing's stays that of the fixed calibration);
      // the crossing catches a size gone grossly wrong: a leaf cutting the
      // fruit makes it look small and far.
      const double range = (*pixel_crossing_ - camera().translation()).norm();
      const bool agrees = (sized - *pixel_crossing_).norm() <= std::max(kSizeAgreementFloor, kSizeAgreement * range);
      current_->estimate = agrees ? sized : *pixel_crossing_;
      current_->depth = agrees ? Fruit::Depth::kConfirmed : Fruit::Depth::kCrossing;
    }
    break;
  }
  return out;
}

MachineOutput HarvestMachine::on_hand_fruit(const fruit_detections_t& msg, rt::Micros now) {
  MachineOutput out;
  const bool looking = state_ == State::kAcquire || state_ == State::kApproach || state_ == State::kReacquire ||
                       state_ == State::kIrApproach;
  if (!current_ || !looking || msg.status != fruit_detections_t::STATUS_OK || !robot_) return out;
  // A fruit filling the image where the gripper axis (the optical axis) meets
  // it, and far larger than the current fruit looks at its estimated depth:
  // a fruit nearer than it, so what the IR reads right in front of the
  // gripper is that fruit, not a leaf (see the leaf rule in IR_APPROACH).
  constexpr double kFills = 0.8;   // of the image height
  constexpr double kNearer = 1.5;  // times the current fruit's expected image diameter
  const double depth = (camera().inverse() * current_->estimate).z();
  const double expected_px = depth > 0.01 ? cfg_.hand_camera.fx * current_->diameter / depth : 0.0;
  for (const auto& f : msg.fruits) {
    const auto& b = f.bbox_px;
    if (f.diameter_px >= kFills * msg.image_height && f.diameter_px > kNearer * expected_px &&
        b[0] <= cfg_.hand_camera.u0 && cfg_.hand_camera.u0 <= b[0] + b[2] && b[1] <= cfg_.hand_camera.v0 &&
        cfg_.hand_camera.v0 <= b[1] + b[3]) {
      fruit_fills_view_rx_ = now;
      // How far its centre lies off the gripper axis [m]: the pixel offset in
      // its own apparent diameters, times the (statistical) fruit diameter.
      fruit_in_front_offset_ = std::hypot(f.u_px - cfg_.hand_camera.u0, f.v_px - cfg_.hand_camera.v0) /
                               std::max(1.0f, f.diameter_px) * current_->diameter;
    }
  }
  // Where the current fruit is in this image: near our last centroid while
  // we follow it; else on the image of the fixed camera's line of sight
  // while its depth is doubtful (nearest the aim point among equals); else
  // at the hand target the reconstructor matched to the fruit in 3D; else at
  // the projected estimate.
  Eigen::Vector2d predicted;
  std::vector<Eigen::Vector2d> sight_px;
  const rt::Micros recent = rt::from_seconds(cfg_.timeouts.lost);
  const bool doubtful = current_->depth_doubtful && current_->sight;
  bool have_point = true;
  if (pixel_ && now - pixel_rx_ <= recent) {
    predicted = {pixel_->u, pixel_->v};
  } else if (!doubtful && hand_target_px_ && now - hand_target_rx_ <= recent) {
    predicted = *hand_target_px_;
  } else {
    have_point = project_point(cfg_.hand_camera, camera().inverse() * current_->estimate, predicted);
    if (current_->sight) {
      const SightLine& l = *current_->sight;
      sight_px = project_segment(cfg_.hand_camera, camera(), l.at(l.near), l.at(l.far));
    }
    if (sight_px.empty() && !have_point) return out;
  }
  // Gate on the distance to the image of the fixed camera's line of sight
  // (or to the point); among detections near the line, the distance to the
  // predicted point decides too: a little for a doubtful depth, more for a
  // plausible one. A neighbour nearer the point but off the line is another
  // fruit at another depth.
  const double tie_weight = doubtful ? 0.01 : 0.25;
  double best = std::numeric_limits<double>::infinity();
  const fruit_t* match = nullptr;
  for (const auto& f : msg.fruits) {
    const Eigen::Vector2d px(f.u_px, f.v_px);
    const double to_point = have_point ? (px - predicted).norm() : 0.0;
    const double d = sight_px.empty() ? to_point : distance_to_polyline(sight_px, px);
    const double score = sight_px.empty() ? d : d + tie_weight * to_point;
    if (d <= cfg_.association_gate_px && score < best) {
      best = score;
      match = &f;
    }
  }
  if (match != nullptr) {
    pixel_ = PixelMeasurement{match->u_px, match->v_px, msg.header.utime};
    pixel_rx_ = now;
    constexpr int kBorder = 2;            // [px]
    constexpr double kMostOfImage = 0.8;  // of the image height
    const auto& b = match->bbox_px;
    pixel_whole_ = b[0] >= kBorder && b[1] >= kBorder && b[0] + b[2] <= msg.image_width - kBorder &&
                   b[1] + b[3] <= msg.image_height - kBorder && match->diameter_px <= kMostOfImage * msg.image_height;
    pixel_crossing_ = pixel_whole_ ? triangulate(*pixel_) : std::nullopt;
  }
  return out;
}

std::optional<Eigen::Vector3d> HarvestMachine::triangulate(const PixelMeasurement& pixel) const {
  if (cfg_.triangulation_gap <= 0.0 || !current_ || !current_->sight || !robot_) return std::nullopt;
  // The newest camera pose: within one image period of the image's, and the
  // arm moves mostly along this very ray while approaching.
  const Eigen::Vector2d xy = undistort_pixel(cfg_.hand_camera, pixel.u, pixel.v);
  const Eigen::Isometry3d cam = camera();
  const Eigen::Vector3d ray = cam.rotation() * Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
  const SightLine& l = *current_->sight;
  const auto c = cross_rays(cam.translation(), ray, l.origin, l.direction);
  if (!c || c->gap > cfg_.triangulation_gap || c->angle < cfg_.min_triangulation_angle) return std::nullopt;
  return c->point;
}

MachineOutput HarvestMachine::on_robot_state(const robot_state_t& msg, rt::Micros now) {
  MachineOutput out;
  robot_ = msg;
  robot_rx_ = now;
  if (!running()) return out;
  switch (msg.mode) {
    case robot_state_t::MODE_FAULT:
      fault("robot fault: " + (msg.fault_text.empty() ? std::string("(no text)") : msg.fault_text), now, out);
      break;
    case robot_state_t::MODE_ESTOP:
      fault("robot reports emergency stop", now, out);
      break;
    case robot_state_t::MODE_DISABLED:
      fault("robot drives disabled", now, out);
      break;
    default:
      break;
  }
  return out;
}

MachineOutput HarvestMachine::on_ir(const ir_range_t& msg, rt::Micros now) {
  ir_ = msg;
  ir_rx_ = now;
  // A triangulating IR sensor folds back nearer than its peak: a fruit inside
  // reads far. Moving forward, a reading just above the grasp range followed
  // by one far beyond it is that fold-back (nothing on the axis jumps away),
  // even if no sample fell inside the few millimetres of the grasp range.
  constexpr double kNear = 0.02, kJump = 0.03;  // [m]
  if (state_ == State::kIrApproach && msg.validity == ir_range_t::VALID) {
    if (msg.range_m <= cfg_.ir_grasp_range + kNear) {
      ir_last_near_ = msg.range_m;
    } else if (ir_last_near_ && msg.range_m > *ir_last_near_ + kJump) {
      ir_folded_ = true;
    }
  }
  return {};
}

MachineOutput HarvestMachine::on_gripper(const gripper_state_t& msg, rt::Micros now) {
  MachineOutput out;
  gripper_ = msg;
  if (!running()) return out;
  if (auto f = gripper_fault()) {
    fault(*f, now, out);
    return out;
  }
  switch (state_) {
    case State::kGrasp:
      if (msg.state == gripper_state_t::STATE_HOLDING) {
        Eigen::Isometry3d g = tool();
        g.translation() -= cfg_.pull_distance * g.rotation().col(2);
        g.linear() = g.linear() * Eigen::AngleAxisd(cfg_.twist_angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        start_goal(g, State::kDetach, now, out);
      } else if (msg.state == gripper_state_t::STATE_CLOSED) {
        out.gripper = gripper_command(gripper_command_t::ACTION_OPEN);
        fail_fruit(fruit_outcome_t::FAILED_GRASP, "gripper closed on nothing", true, now, out);
      }
      break;
    case State::kDetach:
    case State::kDrop:
      if (msg.state != gripper_state_t::STATE_HOLDING) {
        out.gripper = gripper_command(gripper_command_t::ACTION_OPEN);
        fail_fruit(fruit_outcome_t::FAILED_GRASP, "fruit slipped from the gripper", false, now, out);
      }
      break;
    case State::kRelease:
      if (msg.state == gripper_state_t::STATE_OPEN && current_) {
        record(fruit_outcome_t::PICKED, current_->id, current_->estimate, "", current_->selected_at, now, out);
        current_.reset();
        // Out of the canopy the way the gripper came in, then home (with the
        // release at the drop pose, the arm is out of it already).
        if (approach_from_ && cfg_.release_at_detach) {
          start_goal(retreat_goal(), State::kRetreat, now, out);
        } else {
          start_goal(cfg_.home_pose, State::kReturn, now, out);
        }
        approach_from_.reset();
      }
      break;
    default:
      break;
  }
  return out;
}

MachineOutput HarvestMachine::on_operator(const operator_command_t& msg, rt::Micros now) {
  MachineOutput out;
  out.status_changed = true;
  const std::string who = msg.source.empty() ? "operator" : msg.source;
  auto refuse = [&](const std::string& why) {
    note_ = "command refused: " + why;
    out.log = note_ + " (from " + who + ")";
  };
  switch (msg.command) {
    case operator_command_t::START:
      if (estop_) {
        refuse("emergency stop latched");
        return out;
      }
      if (state_ == State::kFault) {
        refuse("fault latched, send RESET_FAULT");
        return out;
      }
      if (running()) {
        refuse("already running");
        return out;
      }
      if (!robot_fresh(now)) {
        refuse("no robot state");
        return out;
      }
      note_ = "started by " + who;
      begin_from_home(now, out);
      break;
    case operator_command_t::PAUSE:
      if (!running() || paused_) {
        refuse("nothing to pause");
        return out;
      }
      paused_ = true;
      paused_at_ = now;
      note_ = "paused by " + who;
      out.robot = stop_command();
      break;
    case operator_command_t::RESUME:
      if (!paused_) {
        refuse("not paused");
        return out;
      }
      paused_ = false;
      // Timeouts do not run while paused.
      if (deadline_ != 0) deadline_ += now - paused_at_;
      goal_progress_at_ += now - paused_at_;
      limiter_.reset();
      note_ = "resumed by " + who;
      break;
    case operator_command_t::ABORT:
      if (current_)
        record(fruit_outcome_t::ABORTED, current_->id, current_->estimate, "operator abort", current_->selected_at, now,
               out);
      current_.reset();
      paused_ = false;
      // Never a way out of a latched e-stop or fault: those stay until cleared.
      if (!estop_ && state_ != State::kFault) {
        enter(State::kIdle, now, out);
        stop_pending_ = false;
      }
      note_ = "aborted by " + who;
      out.robot = stop_command();
      break;
    case operator_command_t::HOME:
      if (estop_) {
        refuse("emergency stop latched");
        return out;
      }
      if (state_ == State::kFault) {
        refuse("fault latched, send RESET_FAULT");
        return out;
      }
      if (!robot_fresh(now)) {
        refuse("no robot state");
        return out;
      }
      if (current_)
        record(fruit_outcome_t::ABORTED, current_->id, current_->estimate, "operator home", current_->selected_at, now,
               out);
      current_.reset();
      paused_ = false;
      start_goal(cfg_.home_pose, State::kHoming, now, out);
      note_ = "homing (" + who + ")";
      break;
    case operator_command_t::RESET_FAULT:
      if (state_ != State::kFault) {
        refuse("no fault to reset");
        return out;
      }
      note_ = "fault reset by " + who;
      enter(State::kIdle, now, out);
      break;
    default: {
      refuse("unknown command " + std::to_string(msg.command));
      return out;
    }
  }
  return out;
}

MachineOutput HarvestMachine::on_estop(const emergency_stop_t& msg, rt::Micros now) {
  MachineOutput out;
  if (msg.engaged) {
    // Stop first, then bookkeeping: the STOP goes out with this very message.
    out.robot = stop_command();
    if (!estop_) {
      if (current_)
        record(fruit_outcome_t::ABORTED, current_->id, current_->estimate, "emergency stop", current_->selected_at, now,
               out);
      current_.reset();
      estop_ = true;
      paused_ = false;
      enter(State::kEstop, now, out);
      note_ = "EMERGENCY STOP from " + msg.source + (msg.reason.empty() ? "" : ": " + msg.reason);
      out.log = note_;
    }
  } else if (msg.clear && estop_) {
    estop_ = false;
    note_ = "emergency stop cleared by " + msg.source;
    out.log = note_;
    enter(State::kIdle, now, out);
    stop_pending_ = false;
  }
  return out;
}

// ---------------------------------------------------------------- control step

MachineOutput HarvestMachine::tick(rt::Micros now) {
  MachineOutput out;
  if (estop_ || state_ == State::kFault) {
    out.robot = stop_command();  // keep the arm held while latched
    return out;
  }
  if (stop_pending_) {
    stop_pending_ = false;
    out.robot = stop_command();
  }
  if (!running()) return out;
  if (!robot_fresh(now)) {
    fault("robot state stale (watchdog)", now, out);
    return out;
  }
  if (paused_) {
    out.robot = stop_command();
    return out;
  }
  if (deadline_ != 0 && now >= deadline_) {
    on_timeout(now, out);
    return out;
  }
  step(now, out);
  return out;
}

void HarvestMachine::step(rt::Micros now, MachineOutput& out) {
  const Twist hold;
  switch (state_) {
    case State::kSelect:
      if (fixed_ && fixed_rx_ > entered_at_) select(now, out);
      return;
    case State::kOrient:
    case State::kBackoff:
    case State::kDetach:
    case State::kDrop:
    case State::kRetreat:
    case State::kReturn:
    case State::kHoming:
      if (!goal_reached()) {
        if (goal_stalled(now)) {
          motion_blocked("stalled", now, out);
          return;
        }
        out.robot = goal_command();  // re-sent every tick as a keep-alive, same goal_id
        return;
      }
      switch (state_) {
        case State::kOrient:
          approach_from_ = tool().translation();
          enter(State::kAcquire, now, out);
          break;
        case State::kBackoff:
          ++ir_attempt_;
          ir_passing_leaf_ = false;
          ir_progress_at_ = now;
          ir_progress_from_ = tool().translation();
          ir_folded_ = false;
          ir_last_near_.reset();
          enter(State::kIrApproach, now, out);
          break;
        case State::kDetach:
          if (cfg_.release_at_detach) {
            // Let the fruit fall onto the catching frame under the canopy where
            // the pull ended (the thesis's HarvestStep5 opens the gripper where
            // it grasped): no carry to a chute.
            enter(State::kRelease, now, out);
            out.gripper = gripper_command(gripper_command_t::ACTION_OPEN);
          } else {
            start_goal(cfg_.drop_pose, State::kDrop, now, out);
          }
          break;
        case State::kDrop:
          enter(State::kRelease, now, out);
          out.gripper = gripper_command(gripper_command_t::ACTION_OPEN);
          break;
        case State::kRetreat:
          start_goal(cfg_.home_pose, State::kReturn, now, out);
          break;
        case State::kReturn:
          if (current_) {
            orient(now, out);  // back from a blocked turn: aim again, from the viewpoint
          } else {
            enter(State::kSelect, now, out);
          }
          break;
        default:
          note_ = "at home";
          enter(State::kIdle, now, out);
          break;
      }
      return;
    case State::kAcquire:
      out.robot = twist_command(hold);
      if (fresh_pixel(now) && pixel_rx_ > entered_at_) enter(State::kApproach, now, out);
      return;
    case State::kReacquire:
      out.robot = twist_command(hold);
      if (fresh_pixel(now) && pixel_rx_ > entered_at_) enter(State::kApproach, now, out);
      return;
    case State::kApproach: {
      const auto pixel = fresh_pixel(now);
      if (!pixel) {
        enter(State::kReacquire, now, out);
        out.robot = twist_command(hold);
        return;
      }
      const Eigen::Isometry3d t = tool();
      if (!current_->depth_doubtful && !cfg_.workspace.contains(current_->estimate)) {
        // Measured by the camera-in-hand (eq. 6-15) where the arm may not go:
        // a fruit beyond reach that the fixed camera's depth put nearer, or a
        // measurement gone wrong in a cluttered view (a neighbour's fragment
        // followed); not certain, so it counts as one attempt.
        const bool moved = (t.translation() - cfg_.home_pose.translation()).norm() > 0.5 * cfg_.retreat_distance;
        fail_fruit(fruit_outcome_t::UNREACHABLE, "the camera-in-hand measures it outside the workspace", moved, now,
                   out);
        return;
      }
      const double remaining = (current_->estimate - t.translation()).dot(t.rotation().col(2));
      if (remaining <= cfg_.ir_switch_distance) {
        ir_attempt_ = 1;
        ir_passing_leaf_ = false;
        ir_progress_at_ = now;
        ir_progress_from_ = t.translation();
        ir_folded_ = false;
        ir_last_near_.reset();
        ir_start_ = t.translation();
        note_ = "IR guidance from " + std::to_string(static_cast<int>(std::lround(remaining * 1000))) + " mm" +
                (current_->depth == Fruit::Depth::kConfirmed  ? " (depth from size, confirmed by the rays' crossing)"
                 : current_->depth == Fruit::Depth::kCrossing ? " (depth from the rays' crossing, the size disagreed)"
                                                              : " (depth from size)");
        enter(State::kIrApproach, now, out);
        // fall through to the first IR-guided command below
      } else {
        ApproachInput in{now, t, camera(), current_->estimate, pixel, std::nullopt};
        out.robot = twist_command(approach_->update(in).twist);
        return;
      }
      [[fallthrough]];
    }
    case State::kIrApproach: {
      const bool ir_fresh = ir_ && now - ir_rx_ <= rt::from_seconds(cfg_.timeouts.ir_stale);
      const bool at_grasp_range =
          (ir_fresh && (ir_->validity == ir_range_t::VALID || ir_->validity == ir_range_t::TOO_NEAR) &&
           ir_->range_m <= cfg_.ir_grasp_range) ||
          ir_folded_;
      // Fruit centre ahead of the tool point by the camera-in-hand's estimate.
      const Eigen::Isometry3d t = tool();
      const double ahead = (current_->estimate - t.translation()).dot(t.rotation().col(2));
      // The IR sees the first thing on its axis: a leaf in front of the fruit
      // reads like the fruit. A reading at the grasp range while an estimate
      // checked against the rays' crossing puts the fruit much farther is
      // that leaf; the approach goes on past it. A depth from the apparent
      // size alone can be decimetres off, so it never overrules the IR.
      // Not when a fruit nearer than the one aimed at fills the hand image on
      // the axis as the reading comes: then the IR reads that fruit, and
      // pushing on would knock it off; the gripper closes on it instead.
      const bool fruit_in_front = !ir_passing_leaf_ && fruit_fills_view_rx_ != 0 &&
                                  now - fruit_fills_view_rx_ <= rt::from_seconds(cfg_.timeouts.lost);
      const bool leaf = at_grasp_range && cfg_.ir_vision_agreement > 0 && current_->depth != Fruit::Depth::kSize &&
                        ahead > cfg_.ir_vision_agreement && !fruit_in_front;
      if (leaf) {  // the leaf, not the fruit
        ir_folded_ = false;
        ir_last_near_.reset();
      }
      if (leaf && !ir_passing_leaf_) {
        ir_passing_leaf_ = true;
        note_ = "IR at " + std::to_string(std::lround(ir_->range_m * 1000)) + " mm, fruit " +
                std::to_string(std::lround(ahead * 1000)) + " mm ahead: past a leaf";
        out.status_changed = true;
      }
      const bool inside = at_grasp_range && !leaf;
      if (inside && fruit_in_front && fruit_in_front_offset_ > cfg_.front_fruit_tolerance) {
        // A fruit in front of the one aimed at, too far off the gripper axis
        // to be captured: closing would knock it off with a finger, pushing
        // on with the palm. Leave it for its own turn; this fruit is tried
        // again after it.
        fail_fruit(fruit_outcome_t::FAILED_GRASP,
                   "a fruit in the way, " + std::to_string(std::lround(fruit_in_front_offset_ * 1000)) +
                       " mm off the gripper axis",
                   true, now, out);
        return;
      }
      if (inside) {
        // Thesis HarvestStep5: close the gripper on the fruit (the arm goes
        // on grasp_advance while the fingers close, then stops).
        out.gripper = gripper_command(gripper_command_t::ACTION_CLOSE);
        grasp_from_ = t.translation();
        enter(State::kGrasp, now, out);
        grasp_step(out);
        return;
      }
      // Progress is 5 mm of tool motion: a tool that makes none for
      // timeouts.stall is blocked (the arm at the edge of its reach, a joint
      // limit) and waits out nothing.
      if ((t.translation() - ir_progress_from_).norm() > 0.005) {
        ir_progress_from_ = t.translation();
        ir_progress_at_ = now;
      }
      const bool blocked = now - ir_progress_at_ > rt::from_seconds(cfg_.timeouts.stall);
      if ((t.translation() - ir_start_).norm() > cfg_.ir_max_travel || ahead < -cfg_.ir_overshoot || blocked) {
        on_timeout(now, out);  // out of travel, past the fruit or blocked: same as the IR timeout
        return;
      }
      if (!ir_fresh) {
        out.robot = twist_command(hold);  // never advance blind
        return;
      }
      const bool sees = ir_->validity == ir_range_t::VALID && !leaf;
      ApproachInput in{now, t, camera(), current_->estimate, fresh_pixel(now), ir_forward_speed(sees)};
      out.robot = twist_command(approach_->update(in).twist);
      return;
    }
    case State::kGrasp:
      grasp_step(out);
      return;
    case State::kRelease:
      out.robot = stop_command();
      return;
    default:
      return;
  }
}

void HarvestMachine::grasp_step(MachineOutput& out) {
  // The IR sensor folds back nearer than its peak, so the grasp reading comes
  // with the fruit centre still ~2 cm ahead of the tool point: going on
  // along the axis while the fingers close centres it between them, and a
  // fruit swaying away along the axis during the close stays inside.
  const Eigen::Isometry3d t = tool();
  const Eigen::Vector3d axis = t.rotation().col(2);
  if ((t.translation() - grasp_from_).dot(axis) >= cfg_.grasp_advance) {
    out.robot = stop_command();
    return;
  }
  Twist forward;
  forward.linear = cfg_.ir_min_speed * axis;
  out.robot = twist_command(forward);
}

}  // namespace harvest::servo
