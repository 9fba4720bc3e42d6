// A simulation scenario: everything the simulator knows and the software
// under test does not (true fruit, true camera calibration and poses), read
// from config/scenarios/*.yaml through lib/config. Lengths in the file are in
// millimetres where the key says `_mm`; everything here is SI.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/board.hpp"
#include "config/config.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::sim {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// A rigid placement of a camera: p_base = rotation * p_camera + position.
// `rotation` may be improper (the thesis's R_ef has determinant -1); it only
// has to be orthogonal, which the loader checks.
struct Placement {
  Mat3 rotation = Mat3::Identity();
  Vec3 position = Vec3::Zero();
};

// `child` is placed in a's frame; the result is in a's parent frame (a * child).
inline Placement compose(const Placement& a, const Placement& child) {
  return {a.rotation * child.rotation, a.position + a.rotation * child.position};
}

struct CameraSetup {
  geometry::CameraModel model;  // the TRUE intrinsics and distortion
  double rate_hz = 30.0;
  double noise_std = 2.0;         // sensor noise [grey levels]
  std::string encoding = "jpeg";  // jpeg | bgr8
  int jpeg_quality = 85;
  // Full sensor the images are binned from (the size the software's
  // calibration refers to); the rendered model is scaled to the image size.
  int sensor_width = 640, sensor_height = 480;
};

struct FruitSpec {
  Vec3 position;          // base frame [m]
  double diameter = 0.0;  // [m]; 0: drawn from the size distribution
  double sticker = 0.0;   // [m] side of a printed square sticker facing the fixed camera (sim/sticker.hpp); 0: none
};

// CAMERA_FIXED_ZOOM, the desired image of teach by zooming: the fixed camera
// turned and zoomed onto one fruit as a pan-tilt-zoom camera would (a
// virtual camera at the fixed camera's true position, upright, its axis
// through the fruit's sticker, or its peel facing it), with the hand camera's
// image size and true intrinsics, the focal length times (distance to the
// sticker) / `distance`: the sticker looks as the camera-in-hand would see it
// from `distance` along the fixed camera's line of sight.
struct Zoom {
  int fruit = -1;         // index into Scenario::fruit; -1: no zoomed camera
  double distance = 0.2;  // [m] from the sticker (or the peel) the zoomed view corresponds to
  double rate_hz = 1.0;   // a snapshot now and then: every new desired image restarts the matching
  bool enabled() const { return fruit >= 0; }
};

struct SizeDistribution {
  double mean = 0.0705, std = 0.0025, min = 0.065, max = 0.076;  // [m]
};

struct Box {
  Vec3 min = Vec3::Zero();
  Vec3 max = Vec3::Zero();
};

struct RandomFruit {
  int count = 0;
  Box region;                    // base frame [m]
  double min_separation = 0.09;  // centre to centre [m]
};

// A leaf put exactly where the scenario wants it (e.g. to hide one fruit
// from the fixed camera); its blade faces `facing`.
struct PlacedLeaf {
  Vec3 centre, facing;
  double length = 0.1, width = 0.06;  // [m]
};

struct Canopy {
  std::vector<PlacedLeaf> placed_leaves;
  int leaves = 0;
  Box region;                                             // where leaf centres are drawn [m]
  double leaf_length_min = 0.05, leaf_length_max = 0.09;  // [m]
  double leaf_width_ratio = 0.45;
  double fruit_clearance = 0.01;  // leaves keep this far from explicit fruit surfaces [m]
  int branches = 0;
  double branch_radius = 0.012;    // [m]
  Vec3 trunk_base = Vec3::Zero();  // branches grow from here towards the fruit [m]
  std::vector<std::array<double, 3>> leaf_colours_rgb{{46, 96, 34}, {64, 118, 44}, {34, 74, 28}, {88, 126, 52}};
};

struct Lighting {
  Vec3 sun_direction = Vec3(-0.5, -0.4, 0.3).normalized();  // towards the sun, base frame
  double ambient = 0.45;
  double diffuse = 0.55;
  double exposure = 1.0;
  std::array<double, 3> sky_rgb{150, 190, 235};
};

// How the simulated cameras draw the world (docs/simulator.md, "Look").
// "flat": the original cartoon shading (Lambert + ambient on flat colours,
// Gaussian noise), which a colour threshold sees as intended; quick tests use
// it. "field": what real canopy photographs have: textured leaves and peel
// (dimples, specular highlights), cast shadows, overexposed sky gaps, dry
// leaves and bark, unripe fruit, auto-exposure and white-balance drift,
// motion blur, vignetting and signal-dependent noise.
struct Look {
  std::string style = "flat";         // flat | field
  double green_fraction = 0.0;        // share of fruit drawn unripe green (field)
  double half_ripe_fraction = 0.0;    // share drawn half-ripe, green patches on orange (field)
  double dry_leaf_fraction = 0.06;    // share of leaves drawn dry and brown (field)
  double exposure_time_s = 0.008;     // shutter open time: motion blur of a moving camera (field)
  bool auto_exposure = true;          // the camera meters each frame and adapts its gain with a lag (field)
  double white_balance_drift = 0.04;  // amplitude of the slow per-channel gain drift (field)
  uint64_t seed = 1;                  // the scenario's seed (not a key): which fruit is green, which leaf dry
  bool field() const { return style == "field"; }
};

struct Wind {
  double amplitude = 0.0;  // fruit sway amplitude [m]
  double frequency_hz = 0.5;
};

struct ArmSetup {
  Vec3 start_tool_position = Vec3(-0.655, 0.785, -0.251);
  Vec3 start_look_at = Vec3(-0.2286, 1.0668, -0.5402);
  double reach = 1.35;              // fruit farther than this from the base origin are unreachable [m]
  double max_linear_speed = 0.381;  // [m/s]
  double max_angular_speed = 1.0;   // [rad/s]
  double max_linear_accel = 1.5;    // [m/s^2]
  // The camera-in-hand's TRUE optical frame in the tool frame (the software
  // has its own estimate, config/cameras/hand_eye.yaml). Default: the
  // simulated gripper's camera, in the palm beside the IR sensor, 17 mm off
  // the gripper axis, its optical axis 1 degree off the tool's (scenario key
  // arm.hand_eye_truth).
  Placement hand_eye = standard_hand_eye();
  static Placement standard_hand_eye();
  // Hardware mode "devices": where the arm's robot base frame truly is in the
  // scenario (world) frame. The software assumes identity, so this is the
  // arm's mounting calibration error.
  Placement mounting;
};

// One run's variation of a scenario (thesis experiments II and III change
// the start pose, or the start pose and the fruit, between runs).
struct Variant {
  Vec3 start_tool_position = Vec3::Zero();
  Vec3 start_look_at = Vec3::Zero();
  std::vector<int> fruit;  // indices into Scenario::fruit present in this run; empty: all
};

struct GripperSetup {
  double close_time_s = 0.6;
  double open_time_s = 0.6;
  double capture_radius = 0.022;     // lateral tolerance of fruit centre to gripper axis [m]
  double capture_axial_min = -0.03;  // fruit centre along tool z relative to the TCP [m]
  double capture_axial_max = 0.035;
  double knock_radius = 0.05;     // closing with a fruit this near but outside capture knocks it off [m]
  double detach_distance = 0.03;  // pull this far from the stem point and the fruit comes off [m]
  double palm_offset = 0.05;      // palm (IR sensor) behind the TCP along tool z [m]
};

struct IrSetup {
  // raw = gain / (range_mm + offset_mm) above the peak range, falling linearly
  // to zero below it (the fold-back of a triangulating IR sensor); 10-bit ADC.
  double gain = 26000.0;
  double offset_mm = 4.0;
  double peak_range = 0.03;  // [m]
  double max_range = 0.35;   // beyond this the sensor sees nothing [m]
  double noise_std = 4.0;    // [counts]
  double rate_hz = 50.0;
};

struct Faults {
  double camera_dropout_start_s = -1.0;  // fixed camera silent from this time ...
  double camera_dropout_duration_s = 0.0;
  double ir_stuck_start_s = -1.0;  // IR raw frozen from this time on
  // Hardware mode "devices" only:
  double drive_fault_start_s = -1.0;     // a drive faults (EMCY, fault reaction) at this time
  int drive_fault_joint = 1;             // 1-based joint; 0: every drive
  int drive_fault_code = 0x7300;         // CiA 301 error code in the EMCY (0x7300: sensor)
  double drive_silent_start_s = -1.0;    // drive_fault_joint falls silent (no heartbeat, no PDOs) ...
  double drive_silent_duration_s = 0.0;  // ... for this long (0: for good)
  double board_silent_start_s = -1.0;    // the end-effector board hangs (sends nothing) ...
  double board_silent_duration_s = 0.0;  // ... for this long (0: for good)
};

// A printed ChArUco calibration board (issue 20; drawn by sim::BoardPrimitive).
using calib::BoardSpec;

// A board on a stand: `pose` takes board-frame points (OpenCV's board frame)
// to the base frame.
struct BoardSetup {
  BoardSpec spec;
  Placement pose;
};

struct Scenario {
  std::string name;
  std::string description;
  uint64_t seed = 1;
  double time_limit_s = 60.0;  // a run ends after this much simulated time
  SizeDistribution fruit_size;
  std::vector<FruitSpec> fruit;
  RandomFruit random_fruit;
  Canopy canopy;
  Lighting lighting;
  Look look;
  Wind wind;
  CameraSetup fixed_camera, hand_camera;
  Placement fixed_camera_truth;  // true extrinsic (the software has its own)
  ArmSetup arm;
  std::vector<Variant> variants;  // run k uses variants[k % size], if any
  GripperSetup gripper;
  IrSetup ir;
  Faults faults;
  std::vector<BoardSetup> boards;  // calibration boards in the scene
  Zoom zoom;

  static Scenario from_config(const config::Node& node);

  // The scenario as run number `run` sees it (its variant applied).
  Scenario for_run(int run) const;
  // The same scenario drawn with another seed (random fruit, looks): another tree of the same kind.
  Scenario with_seed(uint64_t seed) const;
};

// Loads a scenario file and rejects unknown keys. Throws config::Error.
Scenario load_scenario(const std::string& path);

}  // namespace harvest::sim
