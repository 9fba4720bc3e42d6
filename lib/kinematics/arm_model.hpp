// The arm's kinematic model: a Denavit-Hartenberg chain, its mounting in the
// robot base frame, joint limits and the tool/camera offsets, read from
// configuration (config/arm/*.yaml).
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"

namespace harvest::kinematics {

// One revolute joint in standard (distal) DH convention:
// T_{i-1,i} = Rz(theta) Tz(d) Tx(a) Rx(alpha), theta = q + theta_offset.
struct Joint {
  std::string name;
  double a = 0.0;             // [m]
  double alpha = 0.0;         // [rad]
  double d = 0.0;             // [m]
  double theta_offset = 0.0;  // [rad]
  double min = 0.0;           // position limits [rad]
  double max = 0.0;
  double max_velocity = 0.0;      // [rad/s]
  double max_acceleration = 0.0;  // [rad/s^2]
};

struct ArmModel {
  std::string name;
  std::vector<Joint> joints;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();  // DH frame 0 in the robot base frame
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();  // tool centre point in the flange frame
  // Hand camera optical frame in the flange frame: `camera: {position, rpy_deg}`
  // in the flange frame, or `camera: {calibration: FILE}`, the camera in the
  // tool frame as harvest-calibrate writes it (then camera = tool * file).
  Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();
  Eigen::VectorXd home;  // [rad]
  // Posture the IK's null-space motion pulls toward (rest_deg, default home_deg).
  Eigen::VectorXd rest;  // [rad]

  int dof() const { return static_cast<int>(joints.size()); }
  Eigen::VectorXd lower() const;
  Eigen::VectorXd upper() const;
  Eigen::VectorXd max_velocity() const;
  Eigen::VectorXd max_acceleration() const;
  bool within_limits(const Eigen::VectorXd& q, double margin = 0.0) const;
  // Places the camera from a hand-eye calibration file (the camera in the tool frame, as harvest-calibrate
  // hand-eye writes it): camera = tool * file. An unreadable file fails `key` of `node`.
  void place_camera(const config::Node& node, const std::string& key, const std::filesystem::path& file);

  // Reads the `arm` mapping (see config/arm/k1207i.yaml). Throws config::Error.
  static ArmModel from_config(const config::Node& node);
  static std::vector<config::Section> schema();
  // Loads a whole file whose root is the arm mapping and checks for unknown keys.
  static ArmModel load(const std::string& path);
};

// Rotation from roll, pitch, yaw (fixed axes x, y, z: R = Rz(yaw) Ry(pitch) Rx(roll)).
Eigen::Matrix3d rotation_from_rpy(double roll, double pitch, double yaw);

}  // namespace harvest::kinematics
