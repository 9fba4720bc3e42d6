// Uncalibrated teach-by-zooming visual servo controller (thesis chapter 5).
//
// The servo controller calls TbzController::step() once per camera-in-hand
// frame with the matched target points (current image <-> zoomed desired
// image) and gets back the end-effector twist to command. The law is purely
// kinematic (eq. 5-44, 5-62): the output depends on the current measurement
// only, so step() needs no dt and holds no integrator; its only state is the
// plane normal used to pick the homography decomposition from frame to frame.
//
// Frames and signs (the thesis mixes two conventions; this is the one used
// throughout the code and docs/teach-by-zooming.md):
//  * R_d rotates vectors from the desired camera frame F_d into the current
//    camera frame F, so m_i = alpha_i (R_d + x_hd n_d^T) m_di (eq. 5-22, 5-23).
//  * The camera moves toward F_d with omega_c = +lambda_w e_w, e_w = u theta of
//    R_d (the thesis writes -lambda_w with the transposed rotation).
//  * R_r rotates end-effector vectors into the camera frame and t_r is the
//    end-effector origin seen from the camera (eq. 5-33):
//        v_c = R_r v_r + [t_r]x R_r w_r,   w_c = R_r w_r.
//  * Robot twists (v_r, w_r) are expressed in the end-effector frame.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>

#include "geometry/homography.hpp"

namespace harvest::config {
class Node;
}

namespace harvest::control {

struct Twist {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // linear [m/s]
  Eigen::Vector3d w = Eigen::Vector3d::Zero();  // angular [rad/s]
};

// eq. 5-33 and its inverse.
Twist robot_to_camera(const Twist& robot, const Eigen::Matrix3d& R_r, const Eigen::Vector3d& t_r);
Twist camera_to_robot(const Twist& camera, const Eigen::Matrix3d& R_r, const Eigen::Vector3d& t_r);

// Positive function f(m_e1, m_e2) of the translation gain (eq. 5-63), the
// choice of Fang et al. [9]: f = (q + 1 - sqrt((q + 1)^2 - 1)) / 3 with
// q = (m_e1^2 + m_e2^2) / 2. It equals 1/3 on the optical axis and shrinks
// off-axis, so the gain grows where the image Jacobian weakens.
double translation_gain_f(double me1, double me2);

struct TbzParams {
  Eigen::Matrix3d A_hat = Eigen::Matrix3d::Identity();    // best-guess in-hand intrinsics (eq. 5-13, 5-15)
  Eigen::Matrix3d R_r_hat = Eigen::Matrix3d::Identity();  // best-guess camera <- end-effector rotation
  double lambda_w = 2.0;                                  // rotation gain (eq. 5-44)
  bool gain_function = false;              // false: constant lambda_v (thesis simulation); true: eq. 5-63
  double lambda_v = 40.0;                  // constant translation gain
  double kn0 = 1.0, kn1 = 0.0, kn2 = 0.0;  // eq. 5-62, 5-63
  double desired_depth_estimate = 1.0;     // Z*_1 hat [m], best guess of point 1's depth at F_d
  int translation_point = 0;               // which target point drives e_v (the thesis's O_1)
  // Output limits (0 = none). Saturation scales the whole linear (angular)
  // vector, so the direction of the law, and hence stability, is kept.
  double max_linear_speed = 0.381;  // [m/s], thesis 15 in/s
  double max_angular_speed = 1.0;   // [rad/s]
  // Normal of the target plane in F_d used to pick the decomposition on the
  // first frame; later frames use the previous frame's normal.
  Eigen::Vector3d reference_normal = Eigen::Vector3d::UnitZ();

  // Section 5.6.2's controller: the thesis's estimates A_hat and R_r_hat, no output limits.
  static TbzParams thesis_simulation();
  // Reads the `controller` block of config/tbz/*.yaml (see docs/teach-by-zooming.md); a missing key
  // keeps its value in `defaults`.
  static TbzParams from_config(const config::Node& node, const TbzParams& defaults);
  static TbzParams from_config(const config::Node& node);  // defaults: A_hat as the thesis's, others above
};

struct TbzMeasurement {
  geometry::Points2 current_px;  // target points in the camera-in-hand image
  geometry::Points2 desired_px;  // the same points in the zoomed fixed-camera image
  // Optional (>= 4 pairs): vanishing points give R_d from the plane at
  // infinity (section 5.3). Without them R_d comes from decomposing the
  // estimated Euclidean homography, which is exact at the goal.
  geometry::Points2 current_vanishing_px;
  geometry::Points2 desired_vanishing_px;
};

enum class TbzStatus { kOk = 0, kTooFewPoints, kDegenerate, kNoValidSolution, kNonFinite, kBadIndex };
const char* to_string(TbzStatus s);

struct TbzOutput {
  TbzStatus status = TbzStatus::kDegenerate;
  std::string message;                            // why, when status != kOk (the twist is then zero)
  Twist robot;                                    // commanded end-effector twist (end-effector frame)
  Twist camera_estimate;                          // the same twist seen from the camera with R_r_hat, t_r = 0
  Eigen::Vector3d e_w = Eigen::Vector3d::Zero();  // estimated rotation error u^ theta (eq. 5-40)
  Eigen::Vector3d e_v = Eigen::Vector3d::Zero();  // estimated translation error (eq. 5-55)
  double theta = 0.0;
  double alpha1 = 1.0;    // depth ratio Z*_1 / Z_1 of the translation point
  double depth1 = 0.0;    // Z_1 hat (eq. 5-61) [m]
  double lambda_v = 0.0;  // effective translation gain this step
  bool saturated = false;
  bool from_vanishing_points = false;
  bool ok() const { return status == TbzStatus::kOk; }
};

class TbzController {
 public:
  explicit TbzController(TbzParams params);
  TbzOutput step(const TbzMeasurement& m);
  // Forget the normal carried between frames (new target).
  void reset() { last_normal_.reset(); }
  const TbzParams& params() const { return params_; }

 private:
  TbzOutput fail(TbzStatus s, std::string message) const;
  TbzParams params_;
  Eigen::Matrix3d A_hat_inv_;
  std::optional<Eigen::Vector3d> last_normal_;
};

}  // namespace harvest::control
