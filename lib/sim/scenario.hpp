// A simulation scenario: everything the simulator knows and the software
// under test does not (true fruit, true camera calibration and poses), read
// from config/scenarios/*.yaml through lib/config. Lengths in the file are in
// millimetres where the key says `_mm`; everything here is SI.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "calib/board.hpp"
#include "config/config.hpp"
#include "config/schema.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::sim {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// The keys of a scenario file (config/scenarios/*.yaml, docs/simulator.md), per mapping.
namespace scenario_keys {
using config::Key;
using config::Numbers;
namespace top {
inline constexpr Key<std::string> name{.name = "name", .doc = "the scenario's name", .required = true};
inline constexpr Key<std::string> description{"description", "", {}, "", "one line about it"};
inline constexpr Key<int64_t> seed{"seed", 1, {0, std::numeric_limits<int64_t>::max()}, "", "random fruit, leaves and looks are drawn with this seed"};
inline constexpr Key<double> time_limit_s{"time_limit_s", 60.0, {1.0, 3600.0}, "s", "a run ends after this much simulated time"};
}  // namespace top
namespace fruit_size {
inline constexpr Key<double> mean_mm{"mean_mm", 70.5, {20.0, 200.0}, "mm", "mean fruit diameter"};
inline constexpr Key<double> std_mm{"std_mm", 2.5, {0.0, 50.0}, "mm", "its standard deviation"};
inline constexpr Key<double> min_mm{"min_mm", 65.0, {10.0, 200.0}, "mm", "diameters are drawn within [min_mm, max_mm]"};
inline constexpr Key<double> max_mm{"max_mm", 76.0, {10.0, 200.0}, "mm", "at least min_mm"};
}  // namespace fruit_size
namespace fruit {
inline constexpr Key<double> diameter_mm{"diameter_mm", 0.0, {0.0, 200.0}, "mm", "0: drawn from fruit_size"};
inline constexpr Key<double> sticker_mm{"sticker_mm", 0.0, {0.0, 200.0}, "mm", "side of a printed square sticker facing the fixed camera (teach by zooming); 0: none"};
}  // namespace fruit
namespace zoom {  // CAMERA_FIXED_ZOOM, teach by zooming's desired image
inline constexpr Key<int> fruit{"fruit", 0, {0, 10000}, "", "index of the fruit the fixed camera zooms on"};
inline constexpr Key<double> distance_mm{"distance_mm", 200.0, {20.0, 5000.0}, "mm", "the zoomed view is the hand camera's from this far along the fixed camera's line of sight"};
inline constexpr Key<double> rate_hz{"rate_hz", 1.0, {0.1, 120.0}, "Hz", "zoomed snapshots per second"};
}  // namespace zoom
namespace random_fruit {
inline constexpr Key<int> count{"count", 0, {0, 500}, "", "fruit drawn in the region"};
inline constexpr Key<double> min_separation_mm{"min_separation_mm", 90.0, {0.0, 1000.0}, "mm", "centre to centre"};
}  // namespace random_fruit
namespace placed_leaves {
inline constexpr Key<double> length_mm{"length_mm", 100.0, {5.0, 1000.0}, "mm", "leaf length"};
inline constexpr Key<double> width_mm{"width_mm", 60.0, {5.0, 1000.0}, "mm", "leaf width"};
}  // namespace placed_leaves
namespace canopy {
inline constexpr Key<int> leaves{"leaves", 0, {0, 5000}, "", "leaves drawn in the region"};
inline constexpr Key<double> leaf_length_min_mm{"leaf_length_min_mm", 50.0, {5.0, 500.0}, "mm", "drawn leaf lengths: shortest"};
inline constexpr Key<double> leaf_length_max_mm{"leaf_length_max_mm", 90.0, {5.0, 500.0}, "mm", "longest"};
inline constexpr Key<double> leaf_width_ratio{"leaf_width_ratio", 0.45, {0.05, 1.0}, "", "width / length"};
inline constexpr Key<double> fruit_clearance_mm{"fruit_clearance_mm", 10.0, {-100.0, 500.0}, "mm", "leaves keep this far from explicit fruit surfaces"};
inline constexpr Key<int> branches{"branches", 0, {0, 500}, "", "branches from the trunk base towards the fruit"};
inline constexpr Key<double> branch_radius_mm{"branch_radius_mm", 12.0, {1.0, 100.0}, "mm", "branch radius"};
}  // namespace canopy
namespace lighting {
inline constexpr Key<double> ambient{"ambient", 0.45, {0.0, 2.0}, "", "ambient light"};
inline constexpr Key<double> diffuse{"diffuse", 0.55, {0.0, 2.0}, "", "sunlight"};
inline constexpr Key<double> exposure{"exposure", 1.0, {0.05, 10.0}, "", "image brightness factor"};
}  // namespace lighting
namespace look {
inline constexpr Key<double> green_fraction{"green_fraction", 0.0, {0.0, 1.0}, "", "field: share of fruit drawn unripe green"};
inline constexpr Key<double> half_ripe_fraction{"half_ripe_fraction", 0.0, {0.0, 1.0}, "", "field: share drawn half-ripe (at most 1 - green_fraction)"};
inline constexpr Key<double> dry_leaf_fraction{"dry_leaf_fraction", 0.06, {0.0, 1.0}, "", "field: share of leaves drawn dry and brown"};
inline constexpr Key<double> exposure_time_ms{"exposure_time_ms", 8.0, {0.0, 100.0}, "ms", "field: shutter open time (motion blur of a moving camera)"};
inline constexpr Key<bool> auto_exposure{"auto_exposure", true, {}, "", "field: the camera meters each frame and adapts its gain with a lag"};
inline constexpr Key<double> white_balance_drift{"white_balance_drift", 0.04, {0.0, 0.5}, "", "field: amplitude of the slow per-channel gain drift"};
}  // namespace look
namespace wind {
inline constexpr Key<double> amplitude_mm{"amplitude_mm", 0.0, {0.0, 200.0}, "mm", "fruit sway amplitude"};
inline constexpr Key<double> frequency_hz{"frequency_hz", 0.5, {0.0, 20.0}, "Hz", "sway frequency"};
inline constexpr Key<double> gust_factor{"gust_factor", 1.0, {1.0, 10.0}, "", "a gust multiplies the sway amplitude by up to this (1: no gusts)"};
inline constexpr Key<double> gust_rate_hz{"gust_rate_hz", 0.1, {0.0, 10.0}, "1/s", "mean gusts a second (their start times drawn from the seed)"};
inline constexpr Key<double> gust_duration_s{"gust_duration_s", 3.0, {0.1, 60.0}, "s", "a gust rises and falls over this long"};
}  // namespace wind
namespace camera {
inline constexpr Key<int> image_width{"image_width", 320, {16, 4096}, "px", "rendered image width"};
inline constexpr Key<int> image_height{"image_height", 240, {16, 4096}, "px", "rendered image height"};
inline constexpr Key<double> skew{"skew", 0.0, {}, "", "true intrinsics: skew"};
inline constexpr Key<double> rate_hz{"rate_hz", 30.0, {0.1, 120.0}, "Hz", "frames published"};
inline constexpr Key<double> noise_std{"noise_std", 2.0, {0.0, 50.0}, "", "sensor noise (grey levels)"};
inline constexpr Key<int> jpeg_quality{"jpeg_quality", 85, {10, 100}, "", "JPEG quality"};
inline constexpr Key<int> sensor_width{"sensor_width", 640, {16, 8192}, "px", "full sensor the image is binned from (same aspect ratio)"};
inline constexpr Key<int> sensor_height{"sensor_height", 480, {16, 8192}, "px", "its height"};
}  // namespace camera
namespace arm {
inline constexpr Key<double> reach_mm{"reach_mm", 1350.0, {100.0, 5000.0}, "mm", "fruit farther than this from the base origin are unreachable"};
inline constexpr Key<double> max_linear_speed{"max_linear_speed", 0.381, {0.001, 5.0}, "m/s", "the simulated arm's speed limit"};
inline constexpr Key<double> max_angular_speed{"max_angular_speed", 1.0, {0.001, 10.0}, "rad/s", "its angular speed limit"};
inline constexpr Key<double> max_linear_accel{"max_linear_accel", 1.5, {0.01, 50.0}, "m/s^2", "its acceleration limit"};
}  // namespace arm
namespace boards {
inline constexpr Key<double> square_mm{"square_mm", 40.0, {5.0, 500.0}, "mm", "chessboard square side"};
inline constexpr Key<double> marker_mm{"marker_mm", 30.0, {3.0, 500.0}, "mm", "ArUco marker side, smaller than square_mm"};
inline constexpr Key<double> margin_mm{"margin_mm", 20.0, {0.0, 500.0}, "mm", "white plate around the squares"};
}  // namespace boards
namespace gripper {
inline constexpr Key<double> close_time_s{"close_time_s", 0.6, {0.01, 10.0}, "s", "time to close"};
inline constexpr Key<double> open_time_s{"open_time_s", 0.6, {0.01, 10.0}, "s", "time to open"};
inline constexpr Key<double> capture_radius_mm{"capture_radius_mm", 22.0, {1.0, 200.0}, "mm", "lateral tolerance of the fruit centre to the gripper axis"};
inline constexpr Key<double> capture_axial_min_mm{"capture_axial_min_mm", -30.0, {-200.0, 200.0}, "mm", "fruit centre along tool z relative to the TCP: from ..."};
inline constexpr Key<double> capture_axial_max_mm{"capture_axial_max_mm", 35.0, {-200.0, 200.0}, "mm", "... to (above capture_axial_min_mm)"};
inline constexpr Key<double> knock_radius_mm{"knock_radius_mm", 50.0, {1.0, 500.0}, "mm", "closing with a fruit this near but not captured knocks it off"};
inline constexpr Key<double> detach_distance_mm{"detach_distance_mm", 30.0, {1.0, 500.0}, "mm", "pull this far from the stem point and the fruit comes off"};
inline constexpr Key<double> palm_offset_mm{"palm_offset_mm", 50.0, {0.0, 500.0}, "mm", "palm (IR sensor) behind the TCP along tool z"};
}  // namespace gripper
namespace ir {
inline constexpr Key<double> gain{"gain", 26000.0, {1.0, 1e7}, "", "raw = gain / (range_mm + offset_mm) above the peak range"};
inline constexpr Key<double> offset_mm{"offset_mm", 4.0, {0.0, 1000.0}, "mm", "see gain"};
inline constexpr Key<double> peak_range_mm{"peak_range_mm", 30.0, {0.0, 1000.0}, "mm", "below this the reading falls linearly to zero (fold-back)"};
inline constexpr Key<double> max_range_mm{"max_range_mm", 350.0, {1.0, 5000.0}, "mm", "beyond this the sensor sees nothing"};
inline constexpr Key<double> noise_std{"noise_std", 4.0, {0.0, 200.0}, "counts", "reading noise"};
inline constexpr Key<double> rate_hz{"rate_hz", 50.0, {1.0, 1000.0}, "Hz", "readings per second"};
}  // namespace ir
namespace faults {
inline constexpr Key<double> camera_dropout_start_s{"camera_dropout_start_s", -1.0, {}, "s", "the fixed camera falls silent at this time (< 0: never) ..."};
inline constexpr Key<double> camera_dropout_duration_s{"camera_dropout_duration_s", 0.0, {0.0, 3600.0}, "s", "... for this long"};
inline constexpr Key<double> ir_stuck_start_s{"ir_stuck_start_s", -1.0, {}, "s", "the IR reading freezes from this time on (< 0: never)"};
inline constexpr Key<double> drive_fault_start_s{"drive_fault_start_s", -1.0, {}, "s", "devices: a drive faults (EMCY, fault reaction) at this time"};
inline constexpr Key<int> drive_fault_joint{"drive_fault_joint", 1, {0, 64}, "", "devices: which joint, 1-based (0: every drive)"};
inline constexpr Key<int> drive_fault_code{"drive_fault_code", 0x7300, {1, 0xFFFF}, "", "devices: CiA 301 error code in the EMCY (0x7300: sensor)"};
inline constexpr Key<double> drive_silent_start_s{"drive_silent_start_s", -1.0, {}, "s", "devices: drive_fault_joint falls silent at this time ..."};
inline constexpr Key<double> drive_silent_duration_s{"drive_silent_duration_s", 0.0, {0.0, 3600.0}, "s", "... for this long (0: for good)"};
inline constexpr Key<double> board_silent_start_s{"board_silent_start_s", -1.0, {}, "s", "devices: the end-effector board hangs at this time ..."};
inline constexpr Key<double> board_silent_duration_s{"board_silent_duration_s", 0.0, {0.0, 3600.0}, "s", "... for this long (0: for good)"};
}  // namespace faults
namespace lists {
inline constexpr Numbers region_min_mm{"region_min_mm", 3, {0, 0, 0}, "mm", "box where things are drawn: lower corner"};
inline constexpr Numbers region_max_mm{"region_max_mm", 3, {0, 0, 0}, "mm", "upper corner, not below region_min_mm"};
inline constexpr Numbers position_mm{.name = "position_mm", .size = 3, .unit = "mm", .doc = "fruit centre, base frame",
                                     .required = true};
inline constexpr Numbers centre_mm{.name = "centre_mm", .size = 3, .unit = "mm", .doc = "leaf centre",
                                   .required = true};
inline constexpr Numbers facing_mm{.name = "facing_mm", .size = 3, .unit = "mm",
                                   .doc = "a point the leaf faces, away from centre_mm", .required = true};
inline constexpr Numbers trunk_base_mm{"trunk_base_mm", 3, {0, 0, 0}, "mm", "branches grow from here towards the fruit"};
inline constexpr Numbers sun_direction{"sun_direction", 3, {-0.5, -0.4, 0.3}, "",
                                       "towards the sun, base frame (normalised; not zero)"};
inline constexpr config::Choice style{"style", "flat", {"flat", "field"},
                                      "flat colours, or field looks (ripeness, dry leaves, blur, exposure)"};
inline constexpr config::Choice encoding{"encoding", "jpeg", {"jpeg", "bgr8"}, "image encoding"};
inline constexpr Key<double> fx{.name = "fx", .range = {1.0, 1e5}, .unit = "px", .doc = "true focal length x",
                                .derived = "833.57 x image_width / 640 (the thesis's KPCS20-CP1)"};
inline constexpr Key<double> fy{.name = "fy", .range = {1.0, 1e5}, .unit = "px", .doc = "true focal length y",
                                .derived = "767.02 x image_width / 640"};
inline constexpr Key<double> cx{.name = "cx", .unit = "px", .doc = "principal point x, within the image",
                                .derived = "(image_width - 1) / 2"};
inline constexpr Key<double> cy{.name = "cy", .unit = "px", .doc = "principal point y, within the image",
                                .derived = "(image_height - 1) / 2"};
inline constexpr Numbers distortion_coefficients{"distortion_coefficients", 5, {0, 0, 0, 0, 0}, "",
                                                 "true k1, k2, p1, p2, k3"};
inline constexpr Numbers rotation{"rotation", 9, {1, 0, 0, 0, 1, 0, 0, 0, 1}, "", "row-major, orthogonal"};
inline constexpr Numbers translation_mm{"translation_mm", 3, {0, 0, 0}, "mm", "translation"};
inline constexpr Numbers rpy_deg{"rpy_deg", 3, {0, 0, 0}, "deg", "roll, pitch, yaw: R = Rz Ry Rx, as the arm model"};
inline constexpr Numbers hand_eye_translation_mm{"translation_mm", 3, {14, -9, -48}, "mm",
                                                 "the true hand camera in the tool frame: the simulated gripper's"};
inline constexpr Numbers hand_eye_rpy_deg{"rpy_deg", 3, {0.6, -0.8, 1.5}, "deg", "its roll, pitch, yaw"};
inline constexpr Numbers start_tool_position_mm{"start_tool_position_mm", 3, {-655, 785, -251}, "mm",
                                                "where the tool starts"};
inline constexpr Numbers start_look_at_mm{"start_look_at_mm", 3, {-228.6, 1066.8, -540.2}, "mm",
                                          "the point it looks at, away from the start"};
inline constexpr Numbers variant_start_tool_position_mm{.name = "start_tool_position_mm", .size = 3, .unit = "mm",
                                                        .doc = "where the tool starts in this run", .required = true};
inline constexpr Numbers variant_start_look_at_mm{.name = "start_look_at_mm", .size = 3, .unit = "mm",
                                                  .doc = "the point it looks at",
                                                  .derived = "start_tool_position_mm + [0, 1000, 0]"};
inline constexpr Numbers variant_fruit{"fruit", 0, {}, "", "indices of the fruit list present in this run (empty: all)"};
inline constexpr Numbers squares{"squares", 2, {7, 5}, "", "squares across and down, whole numbers 3..40"};
inline constexpr Key<std::string> dictionary{"dictionary", "DICT_5X5_100", {}, "",
                                             "an OpenCV predefined ArUco dictionary (sim/board.cpp lists them)"};
}  // namespace lists
}  // namespace scenario_keys

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
  double rate_hz = scenario_keys::camera::rate_hz.fallback;
  double noise_std = scenario_keys::camera::noise_std.fallback;  // sensor noise [grey levels]
  std::string encoding{scenario_keys::lists::encoding.fallback};
  int jpeg_quality = scenario_keys::camera::jpeg_quality.fallback;
  // Full sensor the images are binned from (the size the software's
  // calibration refers to); the rendered model is scaled to the image size.
  int sensor_width = scenario_keys::camera::sensor_width.fallback;
  int sensor_height = scenario_keys::camera::sensor_height.fallback;
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
  int fruit = -1;  // index into Scenario::fruit; -1: no zoomed camera
  double distance = scenario_keys::zoom::distance_mm.fallback * 1e-3;  // [m] from the sticker (or the peel)
  double rate_hz = scenario_keys::zoom::rate_hz.fallback;  // every new desired image restarts the matching
  bool enabled() const { return fruit >= 0; }
};

struct SizeDistribution {
  double mean = scenario_keys::fruit_size::mean_mm.fallback * 1e-3;  // [m]
  double std = scenario_keys::fruit_size::std_mm.fallback * 1e-3;
  double min = scenario_keys::fruit_size::min_mm.fallback * 1e-3;
  double max = scenario_keys::fruit_size::max_mm.fallback * 1e-3;
};

struct Box {
  Vec3 min = Vec3::Zero();
  Vec3 max = Vec3::Zero();
};

struct RandomFruit {
  int count = scenario_keys::random_fruit::count.fallback;
  Box region;                                                                           // base frame [m]
  double min_separation = scenario_keys::random_fruit::min_separation_mm.fallback * 1e-3;  // centre to centre [m]
};

// A leaf put exactly where the scenario wants it (e.g. to hide one fruit
// from the fixed camera); its blade faces `facing`.
struct PlacedLeaf {
  Vec3 centre, facing;
  double length = scenario_keys::placed_leaves::length_mm.fallback * 1e-3;  // [m]
  double width = scenario_keys::placed_leaves::width_mm.fallback * 1e-3;
};

struct Canopy {
  std::vector<PlacedLeaf> placed_leaves;
  int leaves = scenario_keys::canopy::leaves.fallback;
  Box region;  // where leaf centres are drawn [m]
  double leaf_length_min = scenario_keys::canopy::leaf_length_min_mm.fallback * 1e-3;  // [m]
  double leaf_length_max = scenario_keys::canopy::leaf_length_max_mm.fallback * 1e-3;
  double leaf_width_ratio = scenario_keys::canopy::leaf_width_ratio.fallback;
  // leaves keep this far from explicit fruit surfaces [m]
  double fruit_clearance = scenario_keys::canopy::fruit_clearance_mm.fallback * 1e-3;
  int branches = scenario_keys::canopy::branches.fallback;
  double branch_radius = scenario_keys::canopy::branch_radius_mm.fallback * 1e-3;  // [m]
  Vec3 trunk_base = Vec3::Zero();  // branches grow from here towards the fruit [m]
  std::vector<std::array<double, 3>> leaf_colours_rgb{{46, 96, 34}, {64, 118, 44}, {34, 74, 28}, {88, 126, 52}};
};

struct Lighting {
  // towards the sun, base frame
  Vec3 sun_direction = Vec3(scenario_keys::lists::sun_direction.fallback.data()).normalized();
  double ambient = scenario_keys::lighting::ambient.fallback;
  double diffuse = scenario_keys::lighting::diffuse.fallback;
  double exposure = scenario_keys::lighting::exposure.fallback;
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
  std::string style{scenario_keys::lists::style.fallback};  // flat | field
  double green_fraction = scenario_keys::look::green_fraction.fallback;
  double half_ripe_fraction = scenario_keys::look::half_ripe_fraction.fallback;
  double dry_leaf_fraction = scenario_keys::look::dry_leaf_fraction.fallback;
  double exposure_time_s = scenario_keys::look::exposure_time_ms.fallback * 1e-3;
  bool auto_exposure = scenario_keys::look::auto_exposure.fallback;
  double white_balance_drift = scenario_keys::look::white_balance_drift.fallback;
  uint64_t seed = 1;                 // the scenario's seed (not a key): which fruit is green, which leaf dry
  bool field() const { return style == "field"; }
};

struct Wind {
  double amplitude = scenario_keys::wind::amplitude_mm.fallback * 1e-3;  // fruit sway amplitude [m]
  double frequency_hz = scenario_keys::wind::frequency_hz.fallback;
  // Gusts: the amplitude rises to gust_factor times and falls back (a raised
  // cosine over gust_duration_s), gusts starting at random times, gust_rate_hz
  // of them a second on average, the same for a seed.
  double gust_factor = scenario_keys::wind::gust_factor.fallback;
  double gust_rate_hz = scenario_keys::wind::gust_rate_hz.fallback;
  double gust_duration_s = scenario_keys::wind::gust_duration_s.fallback;
};

struct ArmSetup {
  Vec3 start_tool_position = Vec3(scenario_keys::lists::start_tool_position_mm.fallback.data()) * 1e-3;
  Vec3 start_look_at = Vec3(scenario_keys::lists::start_look_at_mm.fallback.data()) * 1e-3;
  double reach = scenario_keys::arm::reach_mm.fallback * 1e-3;  // farther fruit are unreachable [m]
  double max_linear_speed = scenario_keys::arm::max_linear_speed.fallback;    // [m/s]
  double max_angular_speed = scenario_keys::arm::max_angular_speed.fallback;  // [rad/s]
  double max_linear_accel = scenario_keys::arm::max_linear_accel.fallback;    // [m/s^2]
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
  double close_time_s = scenario_keys::gripper::close_time_s.fallback;
  double open_time_s = scenario_keys::gripper::open_time_s.fallback;
  // [m], from the gripper keys in mm
  double capture_radius = scenario_keys::gripper::capture_radius_mm.fallback * 1e-3;
  double capture_axial_min = scenario_keys::gripper::capture_axial_min_mm.fallback * 1e-3;
  double capture_axial_max = scenario_keys::gripper::capture_axial_max_mm.fallback * 1e-3;
  double knock_radius = scenario_keys::gripper::knock_radius_mm.fallback * 1e-3;
  double detach_distance = scenario_keys::gripper::detach_distance_mm.fallback * 1e-3;
  double palm_offset = scenario_keys::gripper::palm_offset_mm.fallback * 1e-3;
};

struct IrSetup {
  // raw = gain / (range_mm + offset_mm) above the peak range, falling linearly
  // to zero below it (the fold-back of a triangulating IR sensor); 10-bit ADC.
  double gain = scenario_keys::ir::gain.fallback;
  double offset_mm = scenario_keys::ir::offset_mm.fallback;
  double peak_range = scenario_keys::ir::peak_range_mm.fallback * 1e-3;  // [m]
  double max_range = scenario_keys::ir::max_range_mm.fallback * 1e-3;    // sees nothing beyond [m]
  double noise_std = scenario_keys::ir::noise_std.fallback;              // [counts]
  double rate_hz = scenario_keys::ir::rate_hz.fallback;
};

struct Faults {
  double camera_dropout_start_s = scenario_keys::faults::camera_dropout_start_s.fallback;  // fixed camera silent from this time ...
  double camera_dropout_duration_s = scenario_keys::faults::camera_dropout_duration_s.fallback;
  double ir_stuck_start_s = scenario_keys::faults::ir_stuck_start_s.fallback;  // IR raw frozen from this time on
  // Hardware mode "devices" only:
  double drive_fault_start_s = scenario_keys::faults::drive_fault_start_s.fallback;     // a drive faults (EMCY, fault reaction) at this time
  int drive_fault_joint = scenario_keys::faults::drive_fault_joint.fallback;             // 1-based joint; 0: every drive
  int drive_fault_code = scenario_keys::faults::drive_fault_code.fallback;         // CiA 301 error code in the EMCY (0x7300: sensor)
  double drive_silent_start_s = scenario_keys::faults::drive_silent_start_s.fallback;    // drive_fault_joint falls silent (no heartbeat, no PDOs) ...
  double drive_silent_duration_s = scenario_keys::faults::drive_silent_duration_s.fallback;  // ... for this long (0: for good)
  double board_silent_start_s = scenario_keys::faults::board_silent_start_s.fallback;    // the end-effector board hangs (sends nothing) ...
  double board_silent_duration_s = scenario_keys::faults::board_silent_duration_s.fallback;  // ... for this long (0: for good)
};

// A printed ChArUco calibration board (issue 20; drawn by sim::BoardPrimitive).
using calib::BoardSpec;

// A board on a stand: `pose` takes board-frame points (OpenCV's board frame)
// to the base frame. A board clamped to the tool (`on_tool`, the fixed
// camera's extrinsic calibration): `pose` takes them to the tool frame, and
// the board moves with the tool.
struct BoardSetup {
  BoardSpec spec;
  Placement pose;
  bool on_tool = false;
};

struct Scenario {
  std::string name;
  std::string description;
  uint64_t seed = scenario_keys::top::seed.fallback;
  double time_limit_s = scenario_keys::top::time_limit_s.fallback;  // a run ends after this much simulated time
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
  static std::vector<config::Section> schema();

  // The scenario as run number `run` sees it (its variant applied).
  Scenario for_run(int run) const;
  // The same scenario drawn with another seed (random fruit, looks): another tree of the same kind.
  Scenario with_seed(uint64_t seed) const;
};

// Loads a scenario file and rejects unknown keys. Throws config::Error.
Scenario load_scenario(const std::string& path);

}  // namespace harvest::sim
