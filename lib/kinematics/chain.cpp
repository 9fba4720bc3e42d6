#include "kinematics/chain.hpp"

#include <cmath>
#include <stdexcept>

namespace harvest::kinematics {
namespace {
void check_size(const ArmModel& model, const Eigen::VectorXd& q) {
  if (q.size() != model.dof())
    throw std::invalid_argument("joint vector has " + std::to_string(q.size()) + " entries, the arm has " +
                                std::to_string(model.dof()) + " joints");
}
}  // namespace

Eigen::Isometry3d dh_transform(const Joint& joint, double q) {
  const double th = q + joint.theta_offset;
  const double ct = std::cos(th), st = std::sin(th);
  const double ca = std::cos(joint.alpha), sa = std::sin(joint.alpha);
  Eigen::Matrix4d m;
  m << ct, -st * ca, st * sa, joint.a * ct,  //
      st, ct * ca, -ct * sa, joint.a * st,   //
      0, sa, ca, joint.d,                    //
      0, 0, 0, 1;
  return Eigen::Isometry3d(m);
}

std::vector<Eigen::Isometry3d> joint_frames(const ArmModel& model, const Eigen::VectorXd& q) {
  check_size(model, q);
  std::vector<Eigen::Isometry3d> frames;
  frames.reserve(model.joints.size() + 1);
  frames.push_back(model.base);
  for (int i = 0; i < model.dof(); ++i) frames.push_back(frames.back() * dh_transform(model.joints[i], q[i]));
  return frames;
}

Eigen::Isometry3d flange_pose(const ArmModel& model, const Eigen::VectorXd& q) { return joint_frames(model, q).back(); }
Eigen::Isometry3d tool_pose(const ArmModel& model, const Eigen::VectorXd& q) {
  return flange_pose(model, q) * model.tool;
}
Eigen::Isometry3d camera_pose(const ArmModel& model, const Eigen::VectorXd& q) {
  return flange_pose(model, q) * model.camera;
}

Jacobian tool_jacobian(const ArmModel& model, const Eigen::VectorXd& q) {
  const auto frames = joint_frames(model, q);
  const Eigen::Vector3d p = (frames.back() * model.tool).translation();
  Jacobian j(6, model.dof());
  for (int i = 0; i < model.dof(); ++i) {
    // Joint i+1 rotates about z of frame i.
    const Eigen::Vector3d z = frames[i].linear().col(2);
    j.col(i).head<3>() = z.cross(p - frames[i].translation());
    j.col(i).tail<3>() = z;
  }
  return j;
}

Eigen::Vector3d orientation_error(const Eigen::Matrix3d& desired, const Eigen::Matrix3d& current) {
  const Eigen::AngleAxisd aa(desired * current.transpose());
  return aa.angle() * aa.axis();
}

}  // namespace harvest::kinematics
