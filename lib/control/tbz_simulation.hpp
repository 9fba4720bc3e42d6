// The thesis simulation of section 5.6.2, rebuilt: a 3D scene reproducing the
// published pixel coordinates, a camera-in-hand on an end effector with the
// published extrinsics, and the TBZ controller closing the loop.
//
// The thesis gives pixels, not a scene. fit_scene() builds the scene in the
// desired camera frame F_d: the four target points lie on the rays of the
// zoomed desired image p*_i (exact), on a plane whose normal is fitted, at
// depth `desired_depth` for point 1 (the one unpinned scale); the vanishing
// directions are the rays of p*_vi (exact); the initial pose of F is fitted
// by Levenberg-Marquardt to the initial pixels p_i(0) and vanishing points
// p_vi(0). The residuals say how far the thesis's numbers are from any
// rigid scene (see docs/teach-by-zooming.md).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "control/tbz_controller.hpp"

namespace harvest::control {

struct ThesisScenario {
  Eigen::Matrix3d A;       // true camera-in-hand intrinsics (eq. 5-9)
  Eigen::Matrix3d A_f;     // fixed camera
  Eigen::Matrix3d A_star;  // fixed camera after zooming (focal doubled)
  Eigen::Matrix3d R_r;     // true camera <- end-effector rotation (eq. 5-65)
  Eigen::Vector3d t_r;     // true end-effector origin in the camera frame [m] (eq. 5-66)
  geometry::Points2 p_f, p_star, p0;            // fixed, zoomed, initial in-hand pixels
  geometry::Points2 vanish_star, vanish0;       // vanishing points: zoomed fixed camera, initial in-hand
  double desired_depth = 1.0;                   // Z of point 1 at F_d [m] (not given by the thesis)
  double vanishing_weight = 0.01;  // vanishing-point residuals' weight in the scene fit: a weak prior, since no
                                   // rigid scene reproduces both the thesis's points and its vanishing points
  double max_plane_tilt = 60.0 * M_PI / 180.0;  // bound on the target plane's tilt at F_d [rad]

  static ThesisScenario thesis();  // every number of section 5.6.2
  // The `scenario` block of config/tbz/thesis_sim.yaml; missing keys = thesis values.
  static ThesisScenario from_config(const config::Node& node);
  // Its keys and the controller's, as harvest-tbz-sim reads them.
  static std::vector<config::Section> schema();
};

struct SceneFit {
  geometry::Points3 X_d;           // target points in F_d [m]
  geometry::Points3 directions_d;  // vanishing directions in F_d
  Eigen::Vector3d normal_d = Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d R0 = Eigen::Matrix3d::Identity();  // F <- F_d at t = 0
  Eigen::Vector3d t0 = Eigen::Vector3d::Zero();      // origin of F_d seen from F at t = 0 [m]
  std::vector<double> point_residual_px, vanishing_residual_px;
  double rms_point_px = 0, rms_vanishing_px = 0;
  double zoom_factor_fit = 0;  // least-squares k in p* - c = k (p_f - c), c = principal point
  double zoom2_rms_px = 0;     // residual of the thesis's k = 2 (focal doubled)
  double zoomk_rms_px = 0;     // residual with the fitted k
  std::string report_json() const;
};
SceneFit fit_scene(const ThesisScenario& s);

// A camera rigidly mounted on an end effector moving with commanded twists.
class HandEyeRig {
 public:
  // Camera pose in the world frame at t = 0 and the true extrinsics.
  HandEyeRig(const Eigen::Matrix3d& R_world_cam, const Eigen::Vector3d& p_world_cam, const Eigen::Matrix3d& R_r,
             const Eigen::Vector3d& t_r);
  // Integrate an end-effector twist (end-effector frame) over dt: exact
  // rotation increment, first-order translation.
  void apply(const Twist& robot, double dt);
  Eigen::Matrix3d camera_rotation() const;  // world <- camera
  Eigen::Vector3d camera_position() const;  // camera origin in the world [m]
  Eigen::Vector3d to_camera(const Eigen::Vector3d& X_world) const;

 private:
  Eigen::Matrix3d R_ee_;  // world <- end effector
  Eigen::Vector3d p_ee_;
  Eigen::Matrix3d R_r_;
  Eigen::Vector3d t_r_;
};

struct SimOptions {
  double duration = 10.0;      // [s]
  double dt = 1e-3;            // integration step = controller period [s]
  double record_period = 0.01; // [s]
  bool use_vanishing_points = true;
};

struct SimSample {
  double t = 0;
  Eigen::Vector3d e_w, e_v;          // true errors (eq. 5-34, 5-54)
  Eigen::Vector3d e_w_hat, e_v_hat;  // controller's estimates
  Twist robot;                       // commanded end-effector twist
  geometry::Points2 px;              // in-hand pixels of the target points
  Eigen::Vector3d camera_position;   // in F_d [m]
};

struct SimSummary {
  double initial_rotation_error = 0, final_rotation_error = 0;        // |e_w| [rad]
  double initial_translation_error = 0, final_translation_error = 0;  // |e_v| (unitless)
  double max_linear_velocity = 0, max_angular_velocity = 0;           // [m/s], [rad/s]
  double final_position_error_m = 0, final_angle_error_rad = 0;       // camera pose vs F_d
  int failed_steps = 0;
  std::string json() const;  // the six keys of the issue, one line
};

struct SimResult {
  std::vector<SimSample> samples;
  SimSummary summary;
};

SimResult simulate(const ThesisScenario& s, const SceneFit& scene, const TbzParams& params, const SimOptions& opt);

// Slope and R^2 of a least-squares line through (t, ln y) over samples with y > floor.
struct LogFit {
  double slope = 0, r2 = 0;
  int n = 0;
};
LogFit log_linear_fit(const std::vector<double>& t, const std::vector<double>& y, double floor = 1e-300);

// CSV writers (header + one row per sample).
void write_errors_csv(const std::string& path, const SimResult& r);
void write_features_csv(const std::string& path, const SimResult& r);

}  // namespace harvest::control
