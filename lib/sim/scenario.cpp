#include "sim/scenario.hpp"

#include <algorithm>
#include <cmath>

#include "sim/board.hpp"

namespace harvest::sim {
namespace {

constexpr double kMm = 1e-3;

Vec3 vec3(const std::vector<double>& v, double scale = 1.0) { return Vec3(v[0], v[1], v[2]) * scale; }

namespace sk = scenario_keys;
namespace kl = scenario_keys::lists;

Vec3 vec3_mm(const config::Node& n, const config::Numbers& key) { return vec3(n.get(key), kMm); }
// A position whose default is derived from another (key.derived says how).
Vec3 vec3_mm(const config::Node& n, const config::Numbers& key, const Vec3& fallback_m) {
  const std::vector<double> fb{fallback_m.x() / kMm, fallback_m.y() / kMm, fallback_m.z() / kMm};
  return vec3(n.get(key, fb), kMm);
}

Box box_mm(const config::Node& n) {
  Box b{vec3_mm(n, kl::region_min_mm), vec3_mm(n, kl::region_max_mm)};
  for (int i = 0; i < 3; ++i)
    if (b.min[i] > b.max[i]) n.fail("region_max_mm", "a box corner not below region_min_mm on every axis");
  return b;
}

geometry::CameraModel camera_model(const config::Node& n) {
  geometry::CameraModel m;
  m.width = n.get(sk::camera::image_width);
  m.height = n.get(sk::camera::image_height);
  // Default: the thesis's KPCS20-CP1 (fx 833.57, fy 767.02 px at 640x480) scaled to the image width.
  const double scale = m.width / 640.0;
  m.fx = n.get(kl::fx, 833.57 * scale);
  m.fy = n.get(kl::fy, 767.02 * scale);
  // Within the image: a range known once its size is.
  m.cx = n.get<double>(kl::cx.name, (m.width - 1) / 2.0, {0.0, double(m.width)});
  m.cy = n.get<double>(kl::cy.name, (m.height - 1) / 2.0, {0.0, double(m.height)});
  m.skew = n.get(sk::camera::skew);
  const auto dist = n.get(kl::distortion_coefficients);
  std::copy(dist.begin(), dist.end(), m.dist.begin());
  try {
    m.validate();
  } catch (const std::exception& e) {
    n.fail("fx", std::string("a valid camera (") + e.what() + ")");
  }
  return m;
}

CameraSetup camera(const config::Node& n) {
  CameraSetup c;
  c.model = camera_model(n);
  c.rate_hz = n.get(sk::camera::rate_hz);
  c.noise_std = n.get(sk::camera::noise_std);
  c.encoding = n.get(kl::encoding);
  c.jpeg_quality = n.get(sk::camera::jpeg_quality);
  c.sensor_width = n.get(sk::camera::sensor_width);
  c.sensor_height = n.get(sk::camera::sensor_height);
  if (c.sensor_width * c.model.height != c.sensor_height * c.model.width)
    n.fail("sensor_height", "a sensor with the image's aspect ratio (the image is the sensor binned)");
  return c;
}

Mat3 rotation(const config::Node& n, const config::Numbers& key) {
  const auto v = n.get(key);
  Mat3 r;
  r << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  if (!(r * r.transpose()).isApprox(Mat3::Identity(), 1e-6))
    n.fail(key.name, "an orthogonal 3x3 matrix (row-major)");
  return r;
}

Mat3 rotation_rpy_deg(const Vec3& rpy_deg) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  return (Eigen::AngleAxisd(rpy_deg.z() * kDeg, Vec3::UnitZ()) * Eigen::AngleAxisd(rpy_deg.y() * kDeg, Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy_deg.x() * kDeg, Vec3::UnitX()))
      .toRotationMatrix();
}

// {translation_mm, rpy_deg}: R = Rz(yaw) Ry(pitch) Rx(roll), as the arm model.
Placement placement_rpy(const config::Node& n, const config::Numbers& translation, const config::Numbers& rpy_key) {
  Placement p;
  p.position = vec3_mm(n, translation);
  const auto rpy = n.get(rpy_key);
  p.rotation = rotation_rpy_deg(Vec3(rpy[0], rpy[1], rpy[2]));
  return p;
}

// The simulated gripper's camera (see ArmSetup::hand_eye).
Vec3 hand_eye_position() { return Vec3(kl::hand_eye_translation_mm.fallback.data()) * kMm; }
Vec3 hand_eye_rpy_deg() { return Vec3(kl::hand_eye_rpy_deg.fallback.data()); }

}  // namespace

Placement ArmSetup::standard_hand_eye() { return {rotation_rpy_deg(hand_eye_rpy_deg()), hand_eye_position()}; }

Scenario Scenario::from_config(const config::Node& root) {
  Scenario s;
  s.name = root.get(sk::top::name);
  s.description = root.get(sk::top::description);
  s.seed = static_cast<uint64_t>(root.get(sk::top::seed));
  s.time_limit_s = root.get(sk::top::time_limit_s);

  const auto size = root.child("fruit_size");
  s.fruit_size.mean = size.get(sk::fruit_size::mean_mm) * kMm;
  s.fruit_size.std = size.get(sk::fruit_size::std_mm) * kMm;
  s.fruit_size.min = size.get(sk::fruit_size::min_mm) * kMm;
  s.fruit_size.max = size.get(sk::fruit_size::max_mm) * kMm;
  if (s.fruit_size.min > s.fruit_size.max) size.fail("max_mm", "a value >= min_mm");

  if (root.has("fruit")) {
    for (const auto& f : root.children("fruit")) {
      FruitSpec spec;
      spec.position = vec3_mm(f, kl::position_mm);
      spec.diameter = f.get(sk::fruit::diameter_mm) * kMm;
      spec.sticker = f.get(sk::fruit::sticker_mm) * kMm;
      s.fruit.push_back(spec);
    }
  }
  const auto rf = root.child("random_fruit");
  s.random_fruit.count = rf.get(sk::random_fruit::count);
  s.random_fruit.region = box_mm(rf);
  s.random_fruit.min_separation = rf.get(sk::random_fruit::min_separation_mm) * kMm;

  const auto c = root.child("canopy");
  if (c.has("placed_leaves")) {
    for (const auto& l : c.children("placed_leaves")) {
      PlacedLeaf leaf;
      leaf.centre = vec3_mm(l, kl::centre_mm);
      leaf.facing = vec3_mm(l, kl::facing_mm);
      if ((leaf.facing - leaf.centre).norm() < 1e-6) l.fail("facing_mm", "a point away from centre_mm");
      leaf.length = l.get(sk::placed_leaves::length_mm) * kMm;
      leaf.width = l.get(sk::placed_leaves::width_mm) * kMm;
      s.canopy.placed_leaves.push_back(leaf);
    }
  }
  s.canopy.leaves = c.get(sk::canopy::leaves);
  s.canopy.region = box_mm(c);
  s.canopy.leaf_length_min = c.get(sk::canopy::leaf_length_min_mm) * kMm;
  s.canopy.leaf_length_max = c.get(sk::canopy::leaf_length_max_mm) * kMm;
  s.canopy.leaf_width_ratio = c.get(sk::canopy::leaf_width_ratio);
  s.canopy.fruit_clearance = c.get(sk::canopy::fruit_clearance_mm) * kMm;
  s.canopy.branches = c.get(sk::canopy::branches);
  s.canopy.branch_radius = c.get(sk::canopy::branch_radius_mm) * kMm;
  s.canopy.trunk_base = vec3_mm(c, kl::trunk_base_mm);

  const auto l = root.child("lighting");
  s.lighting.sun_direction = vec3(l.get(kl::sun_direction));
  if (s.lighting.sun_direction.norm() < 1e-9) l.fail("sun_direction", "a non-zero vector");
  s.lighting.sun_direction.normalize();
  s.lighting.ambient = l.get(sk::lighting::ambient);
  s.lighting.diffuse = l.get(sk::lighting::diffuse);
  s.lighting.exposure = l.get(sk::lighting::exposure);

  const auto lk = root.child("look");
  s.look.style = lk.get(kl::style);
  s.look.green_fraction = lk.get(sk::look::green_fraction);
  s.look.half_ripe_fraction = lk.get(sk::look::half_ripe_fraction);
  if (s.look.green_fraction + s.look.half_ripe_fraction > 1.0)
    lk.fail("half_ripe_fraction", "at most 1 - green_fraction (the rest is ripe)");
  s.look.dry_leaf_fraction = lk.get(sk::look::dry_leaf_fraction);
  s.look.exposure_time_s = lk.get(sk::look::exposure_time_ms) * 1e-3;
  s.look.auto_exposure = lk.get(sk::look::auto_exposure);
  s.look.white_balance_drift = lk.get(sk::look::white_balance_drift);
  s.look.seed = s.seed;

  const auto w = root.child("wind");
  s.wind.amplitude = w.get(sk::wind::amplitude_mm) * kMm;
  s.wind.frequency_hz = w.get(sk::wind::frequency_hz);
  s.wind.gust_factor = w.get(sk::wind::gust_factor);
  s.wind.gust_rate_hz = w.get(sk::wind::gust_rate_hz);
  s.wind.gust_duration_s = w.get(sk::wind::gust_duration_s);

  const auto cams = root.child("cameras");
  s.fixed_camera = camera(cams.child("fixed"));
  s.hand_camera = camera(cams.child("hand"));
  const auto ext = cams.child("fixed_extrinsic_truth");
  s.fixed_camera_truth.rotation = rotation(ext, kl::rotation);
  s.fixed_camera_truth.position = vec3_mm(ext, kl::translation_mm);

  const auto a = root.child("arm");
  s.arm.start_tool_position = vec3_mm(a, kl::start_tool_position_mm);
  s.arm.start_look_at = vec3_mm(a, kl::start_look_at_mm);
  if ((s.arm.start_look_at - s.arm.start_tool_position).norm() < 1e-3)
    a.fail("start_look_at_mm", "a point away from start_tool_position_mm");
  s.arm.reach = a.get(sk::arm::reach_mm) * kMm;
  s.arm.max_linear_speed = a.get(sk::arm::max_linear_speed);
  s.arm.max_angular_speed = a.get(sk::arm::max_angular_speed);
  s.arm.max_linear_accel = a.get(sk::arm::max_linear_accel);
  s.arm.hand_eye = placement_rpy(a.child("hand_eye_truth"), kl::hand_eye_translation_mm, kl::hand_eye_rpy_deg);
  s.arm.mounting = placement_rpy(a.child("mounting_truth"), kl::translation_mm, kl::rpy_deg);

  if (a.has("variants")) {
    for (const auto& v : a.children("variants")) {
      Variant var;
      var.start_tool_position = vec3_mm(v, kl::variant_start_tool_position_mm);
      var.start_look_at = vec3_mm(v, kl::variant_start_look_at_mm, var.start_tool_position + Vec3(0, 1, 0));
      for (double i : v.get(kl::variant_fruit)) {
        if (i < 0 || i >= static_cast<double>(s.fruit.size()) || i != std::floor(i))
          v.fail("fruit", "indices of entries in the scenario's fruit list");
        var.fruit.push_back(static_cast<int>(i));
      }
      s.variants.push_back(var);
    }
  }

  if (root.has("boards")) {
    for (const auto& b : root.children("boards")) {
      BoardSetup bs;
      const auto sq = b.get(kl::squares);
      if (sq[0] != std::floor(sq[0]) || sq[1] != std::floor(sq[1]) || sq[0] < 3 || sq[1] < 3 || sq[0] > 40 ||
          sq[1] > 40)
        b.fail("squares", "two whole numbers of squares, 3..40");
      bs.spec.squares_x = static_cast<int>(sq[0]);
      bs.spec.squares_y = static_cast<int>(sq[1]);
      bs.spec.square_m = b.get(sk::boards::square_mm) * kMm;
      bs.spec.marker_m = b.get(sk::boards::marker_mm) * kMm;
      if (bs.spec.marker_m >= bs.spec.square_m) b.fail("marker_mm", "smaller than square_mm");
      bs.spec.margin_m = b.get(sk::boards::margin_mm) * kMm;
      bs.spec.dictionary = b.choice(kl::dictionary.name, std::string(kl::dictionary.fallback), board_dictionaries());
      // On a stand (base frame) or clamped to the tool (tool frame), not both.
      bs.on_tool = b.has("tool");
      if (bs.on_tool && b.has("stand")) b.fail("tool", "either a stand or the tool, not both");
      bs.pose = placement_rpy(b.child(bs.on_tool ? "tool" : "stand"), kl::translation_mm, kl::rpy_deg);
      try {
        make_board(bs.spec);
      } catch (const std::invalid_argument& e) {
        b.fail("dictionary", std::string("a board OpenCV can make (") + e.what() + ")");
      }
      s.boards.push_back(bs);
    }
  }

  if (root.has("zoom")) {
    const auto z = root.child("zoom");
    s.zoom.fruit = z.get(sk::zoom::fruit);
    if (s.zoom.fruit >= static_cast<int>(s.fruit.size())) z.fail("fruit", "an index into the scenario's fruit list");
    s.zoom.distance = z.get(sk::zoom::distance_mm) * kMm;
    s.zoom.rate_hz = z.get(sk::zoom::rate_hz);
  }

  const auto g = root.child("gripper");
  s.gripper.close_time_s = g.get(sk::gripper::close_time_s);
  s.gripper.open_time_s = g.get(sk::gripper::open_time_s);
  s.gripper.capture_radius = g.get(sk::gripper::capture_radius_mm) * kMm;
  s.gripper.capture_axial_min = g.get(sk::gripper::capture_axial_min_mm) * kMm;
  s.gripper.capture_axial_max = g.get(sk::gripper::capture_axial_max_mm) * kMm;
  s.gripper.knock_radius = g.get(sk::gripper::knock_radius_mm) * kMm;
  s.gripper.detach_distance = g.get(sk::gripper::detach_distance_mm) * kMm;
  s.gripper.palm_offset = g.get(sk::gripper::palm_offset_mm) * kMm;
  if (s.gripper.capture_axial_min >= s.gripper.capture_axial_max)
    g.fail("capture_axial_max_mm", "a value above capture_axial_min_mm");

  const auto ir = root.child("ir");
  s.ir.gain = ir.get(sk::ir::gain);
  s.ir.offset_mm = ir.get(sk::ir::offset_mm);
  s.ir.peak_range = ir.get(sk::ir::peak_range_mm) * kMm;
  s.ir.max_range = ir.get(sk::ir::max_range_mm) * kMm;
  s.ir.noise_std = ir.get(sk::ir::noise_std);
  s.ir.rate_hz = ir.get(sk::ir::rate_hz);

  const auto f = root.child("faults");
  s.faults.camera_dropout_start_s = f.get(sk::faults::camera_dropout_start_s);
  s.faults.camera_dropout_duration_s = f.get(sk::faults::camera_dropout_duration_s);
  s.faults.ir_stuck_start_s = f.get(sk::faults::ir_stuck_start_s);
  s.faults.drive_fault_start_s = f.get(sk::faults::drive_fault_start_s);
  s.faults.drive_fault_joint = f.get(sk::faults::drive_fault_joint);
  s.faults.drive_fault_code = f.get(sk::faults::drive_fault_code);
  s.faults.drive_silent_start_s = f.get(sk::faults::drive_silent_start_s);
  s.faults.drive_silent_duration_s = f.get(sk::faults::drive_silent_duration_s);
  s.faults.board_silent_start_s = f.get(sk::faults::board_silent_start_s);
  s.faults.board_silent_duration_s = f.get(sk::faults::board_silent_duration_s);
  return s;
}

std::vector<config::Section> Scenario::schema() {
  const std::string where = "A scenario file (config/scenarios/*.yaml), named by the simulator's scenario key "
                            "(docs/simulator.md).";
  using config::section;
  return {
      section("scenario", where, sk::top::name, sk::top::description, sk::top::seed, sk::top::time_limit_s),
      section("scenario.fruit_size", where, sk::fruit_size::mean_mm, sk::fruit_size::std_mm, sk::fruit_size::min_mm,
              sk::fruit_size::max_mm),
      section("scenario.fruit[]", "Fruit placed by hand.", kl::position_mm, sk::fruit::diameter_mm,
              sk::fruit::sticker_mm),
      section("scenario.zoom", "CAMERA_FIXED_ZOOM (teach by zooming): present, the fixed camera zooms on one fruit.",
              sk::zoom::fruit, sk::zoom::distance_mm, sk::zoom::rate_hz),
      section("scenario.random_fruit", where, sk::random_fruit::count, kl::region_min_mm, kl::region_max_mm,
              sk::random_fruit::min_separation_mm),
      section("scenario.canopy", where, sk::canopy::leaves, kl::region_min_mm, kl::region_max_mm,
              sk::canopy::leaf_length_min_mm, sk::canopy::leaf_length_max_mm, sk::canopy::leaf_width_ratio,
              sk::canopy::fruit_clearance_mm, sk::canopy::branches, sk::canopy::branch_radius_mm, kl::trunk_base_mm),
      section("scenario.canopy.placed_leaves[]", "Leaves placed by hand.", kl::centre_mm, kl::facing_mm,
              sk::placed_leaves::length_mm, sk::placed_leaves::width_mm),
      section("scenario.lighting", where, kl::sun_direction, sk::lighting::ambient, sk::lighting::diffuse,
              sk::lighting::exposure),
      section("scenario.look", where, kl::style, sk::look::green_fraction, sk::look::half_ripe_fraction,
              sk::look::dry_leaf_fraction, sk::look::exposure_time_ms, sk::look::auto_exposure,
              sk::look::white_balance_drift),
      section("scenario.wind", where, sk::wind::amplitude_mm, sk::wind::frequency_hz, sk::wind::gust_factor,
              sk::wind::gust_rate_hz, sk::wind::gust_duration_s),
      section("scenario.cameras.fixed, scenario.cameras.hand", "The true cameras, each the same keys.",
              sk::camera::image_width, sk::camera::image_height, kl::fx, kl::fy, kl::cx, kl::cy, sk::camera::skew,
              kl::distortion_coefficients, sk::camera::rate_hz, sk::camera::noise_std, kl::encoding,
              sk::camera::jpeg_quality, sk::camera::sensor_width, sk::camera::sensor_height),
      section("scenario.cameras.fixed_extrinsic_truth", "The true fixed camera extrinsic (the software has its own).",
              kl::rotation, kl::translation_mm),
      section("scenario.arm", where, kl::start_tool_position_mm, kl::start_look_at_mm, sk::arm::reach_mm,
              sk::arm::max_linear_speed, sk::arm::max_angular_speed, sk::arm::max_linear_accel),
      section("scenario.arm.hand_eye_truth", where, kl::hand_eye_translation_mm, kl::hand_eye_rpy_deg),
      section("scenario.arm.mounting_truth", "Hardware devices: where the robot base truly is (the software assumes "
              "identity).", kl::translation_mm, kl::rpy_deg),
      section("scenario.arm.variants[]", "Run k uses variant k modulo their number.",
              kl::variant_start_tool_position_mm, kl::variant_start_look_at_mm, kl::variant_fruit),
      section("scenario.boards[]", "Calibration boards (ChArUco) in the scene.", kl::squares, sk::boards::square_mm,
              sk::boards::marker_mm, sk::boards::margin_mm, kl::dictionary),
      section("scenario.boards[].stand", "Where the board stands (base frame).", kl::translation_mm, kl::rpy_deg),
      section("scenario.boards[].tool", "Or: the board clamped to the tool, its frame in the tool frame; it moves "
              "with the tool (fixed-camera extrinsics).", kl::translation_mm, kl::rpy_deg),
      section("scenario.gripper", where, sk::gripper::close_time_s, sk::gripper::open_time_s,
              sk::gripper::capture_radius_mm, sk::gripper::capture_axial_min_mm, sk::gripper::capture_axial_max_mm,
              sk::gripper::knock_radius_mm, sk::gripper::detach_distance_mm, sk::gripper::palm_offset_mm),
      section("scenario.ir", where, sk::ir::gain, sk::ir::offset_mm, sk::ir::peak_range_mm, sk::ir::max_range_mm,
              sk::ir::noise_std, sk::ir::rate_hz),
      section("scenario.faults", where, sk::faults::camera_dropout_start_s, sk::faults::camera_dropout_duration_s,
              sk::faults::ir_stuck_start_s, sk::faults::drive_fault_start_s, sk::faults::drive_fault_joint,
              sk::faults::drive_fault_code, sk::faults::drive_silent_start_s, sk::faults::drive_silent_duration_s,
              sk::faults::board_silent_start_s, sk::faults::board_silent_duration_s)};
}

Scenario Scenario::for_run(int run) const {
  if (variants.empty()) return *this;
  Scenario s = *this;
  const Variant& v = variants[static_cast<std::size_t>(run) % variants.size()];
  s.arm.start_tool_position = v.start_tool_position;
  s.arm.start_look_at = v.start_look_at;
  if (!v.fruit.empty()) {
    s.fruit.clear();
    for (int i : v.fruit) s.fruit.push_back(fruit[static_cast<std::size_t>(i)]);
    // The zoom follows its fruit into the subset (none when the run leaves it out).
    const auto at = std::find(v.fruit.begin(), v.fruit.end(), zoom.fruit);
    s.zoom.fruit = zoom.enabled() && at != v.fruit.end() ? static_cast<int>(at - v.fruit.begin()) : -1;
  }
  return s;
}

Scenario Scenario::with_seed(uint64_t new_seed) const {
  Scenario s = *this;
  s.seed = s.look.seed = new_seed;
  return s;
}

Scenario load_scenario(const std::string& path) {
  const auto doc = config::Document::load_file(path);
  Scenario s = Scenario::from_config(doc.root());
  doc.check_unused();
  return s;
}

}  // namespace harvest::sim
