#include "kinematics/arm_model.hpp"

#include <cmath>
#include <numbers>

#include "config/schema.hpp"
#include "geometry/transform_file.hpp"

namespace harvest::kinematics {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// The keys of an arm model file (config/arm/k1207i.yaml).
namespace k {
using config::Key;
using config::Numbers;
constexpr Key<std::string> name{"name", "arm", {}, "", "the arm's name"};
constexpr Numbers home_deg{
    .name = "home_deg", .unit = "deg", .doc = "home posture, one per joint, inside the limits", .required = true};
constexpr Numbers rest_deg{.name = "rest_deg",
                           .unit = "deg",
                           .doc = "posture the IK's null-space motion pulls toward, one per joint",
                           .derived = "home_deg"};
namespace joint {
constexpr Key<std::string> name{.name = "name", .doc = "the joint's name", .required = true};
constexpr Key<double> a{"a", 0.0, {}, "m", "DH link length"};
constexpr Key<double> alpha_deg{"alpha_deg", 0.0, {-360.0, 360.0}, "deg", "DH link twist"};
constexpr Key<double> d{"d", 0.0, {}, "m", "DH link offset"};
constexpr Key<double> theta_offset_deg{"theta_offset_deg", 0.0, {-360.0, 360.0}, "deg", "DH joint angle offset"};
constexpr Key<double> min_deg{
    .name = "min_deg", .range = {-360.0, 360.0}, .unit = "deg", .doc = "lower position limit", .required = true};
constexpr Key<double> max_deg{.name = "max_deg",
                              .range = {-360.0, 360.0},
                              .unit = "deg",
                              .doc = "upper position limit, above min_deg",
                              .required = true};
constexpr Key<double> max_velocity_deg_s{
    .name = "max_velocity_deg_s", .range = {0.1, 1000.0}, .unit = "deg/s", .doc = "velocity limit", .required = true};
constexpr Key<double> max_acceleration_deg_s2{.name = "max_acceleration_deg_s2",
                                              .range = {0.1, 10000.0},
                                              .unit = "deg/s^2",
                                              .doc = "acceleration limit",
                                              .required = true};
}  // namespace joint
constexpr Numbers base_position{"position", 3, {0.0, 0.0, 0.0}, "m", "DH frame 0 in the robot base frame"};
constexpr Numbers base_rotation{
    "rotation", 9, {1, 0, 0, 0, 1, 0, 0, 0, 1}, "", "its rotation, row-major, a proper rotation matrix"};
constexpr Numbers tool_position{"position", 3, {0.0, 0.0, 0.1905}, "m", "tool centre point in the flange frame"};
constexpr Numbers tool_rpy{"rpy_deg", 3, {0.0, 0.0, 0.0}, "deg", "its roll, pitch, yaw"};
constexpr Numbers camera_position{
    "position", 3, {0.0, 0.0, 0.1905}, "m", "hand camera optical frame in the flange frame (without calibration)"};
constexpr Numbers camera_rpy{"rpy_deg", 3, {0.0, 0.0, 0.0}, "deg", "its roll, pitch, yaw"};
constexpr Key<config::Path> camera_calibration{
    .name = "calibration",
    .doc = "instead: the camera in the tool frame as harvest-calibrate hand-eye writes it",
    .derived = "none"};
}  // namespace k

// A frame offset given as position [m] and roll-pitch-yaw [deg].
Eigen::Isometry3d read_offset(const config::Node& node, const config::Numbers& position,
                              const config::Numbers& rpy_key) {
  const auto p = node.get(position);
  const auto rpy = node.get(rpy_key);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotation_from_rpy(rpy[0] * kDeg, rpy[1] * kDeg, rpy[2] * kDeg);
  t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return t;
}

Eigen::Isometry3d read_base(const config::Node& node) {
  const auto p = node.get(k::base_position);
  const auto r = node.get(k::base_rotation);
  Eigen::Matrix3d m;
  m << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  if (!(m.transpose() * m).isIdentity(1e-6) || std::abs(m.determinant() - 1.0) > 1e-6)
    node.fail("rotation", "a proper rotation matrix (orthonormal, det +1), row-major");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = m;
  t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return t;
}

}  // namespace

Eigen::Matrix3d rotation_from_rpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::VectorXd ArmModel::lower() const {
  Eigen::VectorXd v(dof());
  for (int i = 0; i < dof(); ++i) v[i] = joints[i].min;
  return v;
}
Eigen::VectorXd ArmModel::upper() const {
  Eigen::VectorXd v(dof());
  for (int i = 0; i < dof(); ++i) v[i] = joints[i].max;
  return v;
}
Eigen::VectorXd ArmModel::max_velocity() const {
  Eigen::VectorXd v(dof());
  for (int i = 0; i < dof(); ++i) v[i] = joints[i].max_velocity;
  return v;
}
Eigen::VectorXd ArmModel::max_acceleration() const {
  Eigen::VectorXd v(dof());
  for (int i = 0; i < dof(); ++i) v[i] = joints[i].max_acceleration;
  return v;
}

void ArmModel::place_camera(const config::Node& node, const std::string& key, const std::filesystem::path& file) {
  try {
    camera = tool * geometry::load_transform_file(file, geometry::Handedness::kProper);
  } catch (const std::exception& e) {
    node.fail(key, std::string("a readable hand-eye calibration (") + e.what() + ")");
  }
}

bool ArmModel::within_limits(const Eigen::VectorXd& q, double margin) const {
  if (q.size() != dof()) return false;
  for (int i = 0; i < dof(); ++i)
    if (q[i] < joints[i].min + margin || q[i] > joints[i].max - margin) return false;
  return true;
}

ArmModel ArmModel::from_config(const config::Node& node) {
  ArmModel m;
  m.name = node.get(k::name);
  const auto joint_nodes = node.children("joints");
  if (joint_nodes.empty() || joint_nodes.size() > 16) node.fail("joints", "a list of 1 to 16 joints");
  for (const auto& j : joint_nodes) {
    Joint joint;
    namespace kj = k::joint;
    joint.name = j.get(kj::name);
    joint.a = j.get(kj::a);
    joint.alpha = j.get(kj::alpha_deg) * kDeg;
    joint.d = j.get(kj::d);
    joint.theta_offset = j.get(kj::theta_offset_deg) * kDeg;
    joint.min = j.get(kj::min_deg) * kDeg;
    joint.max = j.get(kj::max_deg) * kDeg;
    if (joint.max <= joint.min) j.fail("max_deg", "a value greater than min_deg");
    joint.max_velocity = j.get(kj::max_velocity_deg_s) * kDeg;
    joint.max_acceleration = j.get(kj::max_acceleration_deg_s2) * kDeg;
    m.joints.push_back(joint);
  }
  m.base = read_base(node.child("base"));
  m.tool = read_offset(node.child("tool"), k::tool_position, k::tool_rpy);
  const auto camera = node.child("camera");
  if (camera.has(k::camera_calibration.name)) {
    // The camera-in-hand calibration (harvest-calibrate hand-eye) places the
    // camera in the tool frame: flange <- tool <- camera.
    if (camera.has("position") || camera.has("rpy_deg"))
      camera.fail("calibration", "either a calibration file or position/rpy_deg, not both");
    m.place_camera(camera, "calibration", camera.get(k::camera_calibration));
  } else {
    m.camera = read_offset(camera, k::camera_position, k::camera_rpy);
  }
  const auto home = node.get(k::home_deg, m.joints.size());
  m.home = Eigen::Map<const Eigen::VectorXd>(home.data(), static_cast<Eigen::Index>(home.size())) * kDeg;
  if (!m.within_limits(m.home)) node.fail("home_deg", "a configuration inside every joint's limits");
  m.rest = m.home;
  if (node.has(k::rest_deg.name)) {
    const auto rest = node.get(k::rest_deg, m.joints.size());
    m.rest = Eigen::Map<const Eigen::VectorXd>(rest.data(), static_cast<Eigen::Index>(rest.size())) * kDeg;
    if (!m.within_limits(m.rest)) node.fail("rest_deg", "a configuration inside every joint's limits");
  }
  return m;
}

std::vector<config::Section> ArmModel::schema() {
  namespace kj = k::joint;
  const std::string where =
      "An arm model file (config/arm/k1207i.yaml, six_axis.yaml), named by arm_model in the "
      "robot link's, the simulated drives' and the simulator's files.";
  return {config::section("arm_model", where, k::name, k::home_deg, k::rest_deg),
          config::section("arm_model.joints[]", "One per joint, base to flange (Denavit-Hartenberg, standard).",
                          kj::name, kj::a, kj::alpha_deg, kj::d, kj::theta_offset_deg, kj::min_deg, kj::max_deg,
                          kj::max_velocity_deg_s, kj::max_acceleration_deg_s2),
          config::section("arm_model.base", where, k::base_position, k::base_rotation),
          config::section("arm_model.tool", where, k::tool_position, k::tool_rpy),
          config::section("arm_model.camera", where, k::camera_calibration, k::camera_position, k::camera_rpy)};
}

ArmModel ArmModel::load(const std::string& path) {
  auto doc = config::Document::load_file(path);
  ArmModel m = from_config(doc.root());
  doc.check_unused();
  return m;
}

}  // namespace harvest::kinematics
