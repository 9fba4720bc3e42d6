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

#include "config/schema.hpp"
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

// The keys of the `controller` mapping of config/tbz/*.yaml
// (docs/teach-by-zooming.md). A missing key keeps the caller's preset; the
// defaults here are TbzParams{}'s.
namespace tbz_keys {
using config::Key;
inline constexpr Key<double> lambda_w{"lambda_w", 2.0, {1e-6, 1e3}, "1/s", "rotation gain (eq. 5-44)"};
inline constexpr config::Choice lambda_v_mode{
    "lambda_v_mode", "constant", {"constant", "gain_function"},
    "constant lambda_v (the thesis simulation) or the gain function of eq. 5-63"};
inline constexpr Key<double> lambda_v{"lambda_v", 40.0, {1e-6, 1e4}, "", "constant translation gain"};
inline constexpr Key<double> kn0{"kn0", 1.0, {1e-6, 1e4}, "", "gain function coefficient (eq. 5-62, 5-63)"};
inline constexpr Key<double> kn1{"kn1", 0.0, {0.0, 1e4}, "", "gain function coefficient"};
inline constexpr Key<double> kn2{"kn2", 0.0, {0.0, 1e4}, "", "gain function coefficient"};
inline constexpr Key<double> desired_depth_estimate_m{"desired_depth_estimate_m", 1.0, {1e-3, 100.0}, "m",
                                                      "Z*_1 hat: best guess of point 1's depth at F_d"};
inline constexpr Key<int> translation_point{"translation_point", 0, {0, 1000}, "",
                                            "which target point drives e_v (the thesis's O_1)"};
inline constexpr Key<double> max_linear_speed{"max_linear_speed", 0.381, {0.0, 100.0}, "m/s",
                                              "output limit, 0: none (the thesis simulation has none)"};
inline constexpr Key<double> max_angular_speed{"max_angular_speed", 1.0, {0.0, 100.0}, "rad/s",
                                               "output limit, 0: none"};
inline constexpr config::Numbers A_hat{.name = "A_hat", .size = 9,
                                       .doc = "best-guess in-hand intrinsics, row major (eq. 5-13, 5-15), invertible",
                                       .derived = "the thesis's"};
inline constexpr config::Numbers R_r_hat{.name = "R_r_hat", .size = 9,
                                         .doc = "best-guess camera <- end-effector rotation, row major",
                                         .derived = "identity (thesis simulation: the thesis's)"};
inline constexpr config::Numbers reference_normal{"reference_normal", 3, {0, 0, 1}, "",
                                                  "target plane normal in F_d picking the first decomposition"};
}  // namespace tbz_keys

struct TbzParams {
  Eigen::Matrix3d A_hat = Eigen::Matrix3d::Identity();    // best-guess in-hand intrinsics (eq. 5-13, 5-15)
  Eigen::Matrix3d R_r_hat = Eigen::Matrix3d::Identity();  // best-guess camera <- end-effector rotation
  double lambda_w = tbz_keys::lambda_w.fallback;          // rotation gain (eq. 5-44)
  // false: constant lambda_v (thesis simulation); true: eq. 5-63
  bool gain_function = tbz_keys::lambda_v_mode.fallback == "gain_function";
  double lambda_v = tbz_keys::lambda_v.fallback;  // constant translation gain
  double kn0 = tbz_keys::kn0.fallback, kn1 = tbz_keys::kn1.fallback, kn2 = tbz_keys::kn2.fallback;
  double desired_depth_estimate = tbz_keys::desired_depth_estimate_m.fallback;  // Z*_1 hat [m]
  int translation_point = tbz_keys::translation_point.fallback;  // which target point drives e_v
  // Output limits (0 = none). Saturation scales the whole linear (angular)
  // vector, so the direction of the law, and hence stability, is kept.
  double max_linear_speed = tbz_keys::max_linear_speed.fallback;
  double max_angular_speed = tbz_keys::max_angular_speed.fallback;
  // Normal of the target plane in F_d used to pick the decomposition on the
  // first frame; later frames use the previous frame's normal.
  Eigen::Vector3d reference_normal = Eigen::Vector3d::UnitZ();

  // Section 5.6.2's controller: the thesis's estimates A_hat and R_r_hat, no output limits.
  static TbzParams thesis_simulation();
  // Reads the `controller` block of config/tbz/*.yaml (see docs/teach-by-zooming.md); a missing key
  // keeps its value in `defaults`.
  static TbzParams from_config(const config::Node& node, const TbzParams& defaults);
  static TbzParams from_config(const config::Node& node);  // defaults: A_hat as the thesis's, others above
  static config::Section schema(const std::string& path, const std::string& where);
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
