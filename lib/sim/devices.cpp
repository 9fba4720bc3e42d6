#include "sim/devices.hpp"

#include <array>
#include <optional>
#include <stdexcept>

#include "config/schema.hpp"
#include "kinematics/chain.hpp"
#include "kinematics/diff_ik.hpp"
#include "sim/scene.hpp"
#include "canopen/master.hpp"
#include "simdrive/sim_drives_node.hpp"

namespace harvest::sim {

DevicesConfig DevicesConfig::from_config(const config::Node& n) {
  namespace k = devices_keys;
  DevicesConfig c;
  const auto path = n.get(k::drives_config);
  c.drives_config_path = path.string();
  auto doc = config::Document::load_file(path);
  try {
    // The same reader as harvest-sim-drives, so the simulator's drives are
    // exactly the ones that process would simulate.
    const simdrive::SimDrivesConfig drives = simdrive::SimDrivesConfig::from_config(doc.root());
    c.model = kinematics::ArmModel::load(doc.root().get(simdrive::sim_drives_keys::arm_model).string());
    c.drives = drives.drives;
    c.drive_step_us = drives.step_us;
    c.bus = drives.bus;
    doc.check_unused();
  } catch (const config::Error& e) {
    n.fail("drives_config", std::string("a valid simulated drives file: ") + e.what());
  }
  c.bus = canopen::bus_from_config(n, k::bus, c.bus);
  const auto b = n.child("board");
  c.board_host = b.get(k::board_host);
  c.board_port = b.get(k::board_port);
  c.board_service_us = b.get(k::service_period_ms) * 1000;
  c.board.ir_rate_hz = b.get(endeffector::board_keys::ir_rate_hz);
  c.board.grip_rate_hz = b.get(endeffector::board_keys::grip_rate_hz);
  c.board.default_force_n = b.get(endeffector::board_keys::default_force_n);
  c.board.firmware = b.get(k::board_firmware);
  return c;
}

std::vector<config::Section> DevicesConfig::schema(const std::string& path, const std::string& where) {
  namespace k = devices_keys;
  namespace bk = endeffector::board_keys;
  return {config::section(path, where, k::drives_config, k::bus),
          config::section(path + ".board", where, k::board_host, k::board_port, k::service_period_ms, bk::ir_rate_hz,
                          bk::grip_rate_hz, bk::default_force_n, k::board_firmware)};
}

Placement to_placement(const Eigen::Isometry3d& t) { return {t.linear(), t.translation()}; }

Eigen::Isometry3d to_isometry(const Placement& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = p.rotation;
  t.translation() = p.position;
  return t;
}

StartConfiguration start_joints(const kinematics::ArmModel& model, const Eigen::Isometry3d& mounting,
                                const Placement& start) {
  const Eigen::Isometry3d to_robot = mounting.inverse();
  const Eigen::Isometry3d home = kinematics::tool_pose(model, model.home);
  auto solve = [&](const Mat3& rotation) -> std::optional<Eigen::VectorXd> {
    const Eigen::Isometry3d goal = to_robot * to_isometry({rotation, start.position});
    // The arm got to its start pose from home: follow the straight path there
    // in small steps, so the joints are the ones continuous with home (same
    // elbow and wrist branch, as the robot link's motions keep them), not
    // whichever solution a cold solve happens to find. A cold solve is the
    // fallback when the straight path leaves the joint ranges.
    constexpr int kSteps = 40;
    kinematics::PoseSolveOptions step_options;
    step_options.restarts = 0;
    const Eigen::Quaterniond from(home.linear()), to(goal.linear());
    std::optional<Eigen::VectorXd> q = model.home;
    for (int k = 1; k <= kSteps && q; ++k) {
      const double f = static_cast<double>(k) / kSteps;
      Eigen::Isometry3d via = Eigen::Isometry3d::Identity();
      via.translation() = home.translation() + f * (goal.translation() - home.translation());
      via.linear() = from.slerp(f, to).toRotationMatrix();
      q = kinematics::solve_pose(model, via, *q, step_options);
    }
    if (q) return q;
    return kinematics::solve_pose(model, goal, model.home);
  };
  if (auto q = solve(start.rotation)) return {*q, 0.0};
  // The exact orientation is out of the wrist's range: keep the position and
  // turn the tool toward a comfortable orientation (the model's home one, or
  // looking at the tree, down, up or sideways) only as far as needed, by
  // bisection on the rotation between them.
  const Eigen::Quaterniond want(start.rotation);
  std::vector<Mat3> comfortable{(mounting * kinematics::tool_pose(model, model.home)).linear()};
  const std::array<Vec3, 5> directions{Vec3(0, 1, 0), Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 0, 1), Vec3(0, 0, -1)};
  for (const Vec3& d : directions) comfortable.push_back(look_at_rotation(start.position, start.position + d));
  Eigen::Quaterniond easy = want;
  std::optional<Eigen::VectorXd> q;
  for (const Mat3& r : comfortable) {
    if ((q = solve(r))) {
      easy = Eigen::Quaterniond(r);
      break;
    }
  }
  auto blended = [&](double f) { return Mat3(want.slerp(f, easy).toRotationMatrix()); };
  if (!q) {
    const Vec3 p = start.position * 1e3;
    throw std::runtime_error("the arm '" + model.name + "' cannot reach the scenario's start position (" +
                             std::to_string(p.x()) + ", " + std::to_string(p.y()) + ", " + std::to_string(p.z()) +
                             ") mm within its joint limits");
  }
  double lo = 0.0, hi = 1.0;  // lo: unreachable, hi: reachable
  for (int i = 0; i < 6; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (auto qm = solve(blended(mid))) {
      hi = mid;
      q = qm;
    } else {
      lo = mid;
    }
  }
  return {*q, want.angularDistance(want.slerp(hi, easy))};
}

std::vector<simdrive::SimDriveConfig> DeviceArm::with_start(std::vector<simdrive::SimDriveConfig> d,
                                                            const Eigen::VectorXd& q0) {
  if (static_cast<Eigen::Index>(d.size()) != q0.size())
    throw std::invalid_argument("DeviceArm: " + std::to_string(d.size()) + " drives for " + std::to_string(q0.size()) +
                                " joints");
  for (std::size_t i = 0; i < d.size(); ++i) d[i].initial_position = q0[static_cast<Eigen::Index>(i)];
  return d;
}

DeviceArm::DeviceArm(can::CanBus& bus, kinematics::ArmModel model, std::vector<simdrive::SimDriveConfig> drives,
                     const Eigen::VectorXd& q0, const Eigen::Isometry3d& mounting, const Placement& hand_eye)
    : model_(std::move(model)), set_(bus, with_start(std::move(drives), q0)), mounting_(mounting), hand_eye_(hand_eye) {
  if (static_cast<int>(set_.size()) != model_.dof())
    throw std::invalid_argument("DeviceArm: the drive list does not match the arm model");
  update_pose();
}

void DeviceArm::advance(rt::Micros now) {
  set_.advance(now);
  update_pose();
}

Eigen::VectorXd DeviceArm::joints() const {
  const auto p = set_.positions();
  return Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<Eigen::Index>(p.size()));
}

void DeviceArm::update_pose() {
  const Eigen::VectorXd q = joints();
  tool_ = to_placement(mounting_ * kinematics::tool_pose(model_, q));
  hand_camera_ = compose(tool_, hand_eye_);
}

void BoardGripper::command(const endeffector::GripperGoal& goal, rt::Micros now) {
  using Kind = endeffector::GripperGoal::Kind;
  const double t = seconds_(now);
  force_limit_ = goal.force_n > 0 ? goal.force_n : default_force_;
  switch (goal.kind) {
    case Kind::kOpen:
      gripper_.open(t);
      break;
    case Kind::kClose:
      gripper_.close(t);
      break;
    case Kind::kMove:  // the fingers have two ends of travel: move towards the nearer one
      if (goal.position < gripper_.opening())
        gripper_.close(t);
      else if (goal.position > gripper_.opening())
        gripper_.open(t);
      break;
    case Kind::kStop:
      break;  // the simulated fingers always finish a stroke
  }
}

endeffector::GripperReading BoardGripper::read(rt::Micros /*now*/) {
  using endeffector::GripState;
  endeffector::GripperReading r;
  switch (gripper_.phase()) {
    case GripperPhase::kOpen:
      r.state = GripState::kOpen;
      break;
    case GripperPhase::kClosing:
      r.state = GripState::kClosing;
      break;
    case GripperPhase::kClosed:
      r.state = GripState::kClosed;
      break;
    case GripperPhase::kHolding:
      r.state = GripState::kHolding;
      break;
    case GripperPhase::kOpening:
      r.state = GripState::kOpening;
      break;
  }
  r.position = gripper_.opening();
  r.force_n = gripper_.phase() == GripperPhase::kHolding ? force_limit_ : 0.0;
  return r;
}

}  // namespace harvest::sim
