#include "kinematics/arm_model.hpp"

#include <cmath>
#include <numbers>

#include "geometry/transform_file.hpp"

namespace harvest::kinematics {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A frame offset given as position [m] and roll-pitch-yaw [deg].
Eigen::Isometry3d read_offset(const config::Node& node, const std::vector<double>& position) {
  const auto p = node.numbers("position", position, 3);
  const auto rpy = node.numbers("rpy_deg", {0.0, 0.0, 0.0}, 3);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotation_from_rpy(rpy[0] * kDeg, rpy[1] * kDeg, rpy[2] * kDeg);
  t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return t;
}

Eigen::Isometry3d read_base(const config::Node& node) {
  const auto p = node.numbers("position", {0.0, 0.0, 0.0}, 3);
  const auto r = node.numbers("rotation", {1, 0, 0, 0, 1, 0, 0, 0, 1}, 9);
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

bool ArmModel::within_limits(const Eigen::VectorXd& q, double margin) const {
  if (q.size() != dof()) return false;
  for (int i = 0; i < dof(); ++i)
    if (q[i] < joints[i].min + margin || q[i] > joints[i].max - margin) return false;
  return true;
}

ArmModel ArmModel::from_config(const config::Node& node) {
  ArmModel m;
  m.name = node.get<std::string>("name", "arm");
  const auto joint_nodes = node.children("joints");
  if (joint_nodes.empty() || joint_nodes.size() > 16) node.fail("joints", "a list of 1 to 16 joints");
  for (const auto& j : joint_nodes) {
    Joint joint;
    joint.name = j.required<std::string>("name");
    joint.a = j.get<double>("a", 0.0);
    joint.alpha = j.get<double>("alpha_deg", 0.0, {-360.0, 360.0}) * kDeg;
    joint.d = j.get<double>("d", 0.0);
    joint.theta_offset = j.get<double>("theta_offset_deg", 0.0, {-360.0, 360.0}) * kDeg;
    joint.min = j.required<double>("min_deg", {-360.0, 360.0}) * kDeg;
    joint.max = j.required<double>("max_deg", {-360.0, 360.0}) * kDeg;
    if (joint.max <= joint.min) j.fail("max_deg", "a value greater than min_deg");
    joint.max_velocity = j.required<double>("max_velocity_deg_s", {0.1, 1000.0}) * kDeg;
    joint.max_acceleration = j.required<double>("max_acceleration_deg_s2", {0.1, 10000.0}) * kDeg;
    m.joints.push_back(joint);
  }
  m.base = read_base(node.child("base"));
  m.tool = read_offset(node.child("tool"), {0.0, 0.0, 0.1905});
  const auto camera = node.child("camera");
  if (camera.has("calibration")) {
    // The camera-in-hand calibration (harvest-calibrate hand-eye) places the
    // camera in the tool frame: flange <- tool <- camera.
    if (camera.has("position") || camera.has("rpy_deg"))
      camera.fail("calibration", "either a calibration file or position/rpy_deg, not both");
    const auto file = camera.file_path("calibration");
    try {
      m.camera = m.tool * geometry::load_transform_file(file, geometry::Handedness::kProper);
    } catch (const std::exception& e) {
      camera.fail("calibration", std::string("a readable hand-eye calibration (") + e.what() + ")");
    }
  } else {
    m.camera = read_offset(camera, {0.0, 0.0, 0.1905});
  }
  const auto home = node.numbers("home_deg", m.joints.size());
  m.home = Eigen::Map<const Eigen::VectorXd>(home.data(), static_cast<Eigen::Index>(home.size())) * kDeg;
  if (!m.within_limits(m.home)) node.fail("home_deg", "a configuration inside every joint's limits");
  m.rest = m.home;
  if (node.has("rest_deg")) {
    const auto rest = node.numbers("rest_deg", m.joints.size());
    m.rest = Eigen::Map<const Eigen::VectorXd>(rest.data(), static_cast<Eigen::Index>(rest.size())) * kDeg;
    if (!m.within_limits(m.rest)) node.fail("rest_deg", "a configuration inside every joint's limits");
  }
  return m;
}

ArmModel ArmModel::load(const std::string& path) {
  auto doc = config::Document::load_file(path);
  ArmModel m = from_config(doc.root());
  doc.check_unused();
  return m;
}

}  // namespace harvest::kinematics
