// The reconstructor's logic (no transport): fruit detections of the fixed
// camera and the camera-in-hand -> 3D targets in the robot base frame, with
// fruit identity (see docs/perception.md).
//
// Fixed camera: p_base = R_ef p_cam + T_ef (eq. 4-1, 6-13); its pixel tracks
// give the global fruit ids. Camera-in-hand: p_base = T_base_cam(t) p_cam with
// the camera pose of ROBOT_STATE (the robot link's T_base_tool(t) T_tool_cam,
// T_tool_cam the hand-eye calibration) interpolated at the image time; its detections take
// the global id of the fixed-camera fruit they match in 3D, or 100000 + their
// hand track id when they match none.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "config/schema.hpp"
#include "geometry/camera_model.hpp"
#include "geometry/pose_history.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "vision/reconstruction.hpp"
#include "vision/tracking.hpp"

namespace harvest::config {
class Node;
}

namespace harvest::vision {

inline constexpr int32_t kUnassociatedIdBase = 100000;

namespace reconstructor_keys {
using config::Key;
using config::Path;
inline constexpr Key<Path> fixed_calibration{"calibration", "config/cameras/fixed.yaml", {}, "",
                                             "the fixed camera's intrinsic calibration"};
inline constexpr Key<Path> extrinsic{"extrinsic", "config/cameras/fixed_extrinsic.yaml", {}, "",
                                     "fixed camera -> base transform (the thesis's eq. 4-1 has determinant -1)"};
inline constexpr Key<double> extrinsic_sigma_m{"extrinsic_sigma_m", 0.03, {0.0, 1.0}, "m",
                                               "its calibration error, isotropic 1 sigma"};
inline constexpr Key<Path> hand_calibration{"calibration", "config/cameras/hand.yaml", {}, "",
                                            "the hand camera's intrinsic calibration"};
inline constexpr Key<double> pose_sigma_m{"pose_sigma_m", 0.005, {0.0, 1.0}, "m",
                                          "error of the hand camera's pose, isotropic 1 sigma"};
inline constexpr Key<int64_t> max_state_gap_ms{"max_state_gap_ms", 100, {1, 10'000}, "ms",
                                               "robot states around a hand image at most this far apart"};
inline constexpr Key<double> gate_diameters{"gate_diameters", 1.0, {0.01, 100.0}, "",
                                            "a detection within this many diameters continues a track"};
inline constexpr Key<int> max_missed_frames{"max_missed_frames", 10, {0, 100000}, "",
                                            "a track missed this many frames ends"};
inline constexpr Key<double> association_gate_chi2{"association_gate_chi2", 11.34, {0.0, 1e6}, "",
                                                   "hand-to-fixed association gate (99 % for 3 degrees of freedom)"};
inline constexpr Key<int64_t> fixed_memory_s{"fixed_memory_s", 60, {0, 86400}, "s",
                                             "keep a fixed-camera fruit this long after last seen"};
}  // namespace reconstructor_keys

struct ReconstructorConfig {
  geometry::CameraModel fixed_camera;
  Eigen::Isometry3d fixed_extrinsic = thesis_fixed_camera_extrinsic();  // camera -> base
  double fixed_extrinsic_sigma_m = reconstructor_keys::extrinsic_sigma_m.fallback;
  geometry::CameraModel hand_camera;
  double hand_pose_sigma_m = reconstructor_keys::pose_sigma_m.fallback;
  int64_t max_state_gap_us = reconstructor_keys::max_state_gap_ms.fallback * 1000;
  FruitStatistics fruit;
  PixelNoise noise;
  double track_gate_diameters = reconstructor_keys::gate_diameters.fallback;
  int track_max_missed = reconstructor_keys::max_missed_frames.fallback;
  double association_gate_chi2 = reconstructor_keys::association_gate_chi2.fallback;
  int64_t fixed_memory_us = reconstructor_keys::fixed_memory_s.fallback * 1'000'000;

  static ReconstructorConfig from_yaml(const config::Node& node);
  static std::vector<config::Section> schema();
};

class Reconstructor {
 public:
  explicit Reconstructor(ReconstructorConfig config);

  void on_robot_state(const robot_state_t& state);
  void on_harvest_status(const harvest_status_t& status) { current_fruit_id_ = status.current_fruit_id; }
  // nullopt (with last_error() set) when the detections cannot be placed in
  // 3D: bad image, or for the hand camera no robot state near the image time.
  std::optional<targets_t> on_fixed(const fruit_detections_t& detections);
  std::optional<targets_t> on_hand(const fruit_detections_t& detections);

  const std::string& last_error() const { return last_error_; }
  // Latest base-frame estimate of each fixed-camera fruit by global id.
  const std::map<int32_t, Estimate3d>& known_fruit() const { return known_; }

 private:
  targets_t make_targets(const fruit_detections_t& d, const geometry::CameraModel& cam,
                         const Eigen::Isometry3d& cam_to_base, double transform_sigma, const std::string& camera,
                         std::vector<Estimate3d>& estimates) const;

  ReconstructorConfig config_;
  geometry::PoseHistory camera_poses_;  // ROBOT_STATE.camera_pose
  PixelTracker fixed_tracker_, hand_tracker_;
  HandAssociator associator_;
  std::map<int32_t, Estimate3d> known_;
  std::map<int32_t, int64_t> last_seen_;
  int32_t current_fruit_id_ = -1;
  int32_t fixed_selected_id_ = -1;
  std::string last_error_;
};

}  // namespace harvest::vision
