#include "sim/scenario.hpp"

#include <algorithm>
#include <cmath>

#include "sim/board.hpp"

namespace harvest::sim {
namespace {

constexpr double kMm = 1e-3;

Vec3 vec3(const std::vector<double>& v, double scale = 1.0) { return Vec3(v[0], v[1], v[2]) * scale; }

Vec3 vec3_mm(const config::Node& n, const std::string& key, const Vec3& fallback_m) {
  const std::vector<double> fb{fallback_m.x() / kMm, fallback_m.y() / kMm, fallback_m.z() / kMm};
  return vec3(n.numbers(key, fb, 3), kMm);
}

Box box_mm(const config::Node& n, const Box& fallback) {
  Box b{vec3_mm(n, "region_min_mm", fallback.min), vec3_mm(n, "region_max_mm", fallback.max)};
  for (int i = 0; i < 3; ++i)
    if (b.min[i] > b.max[i]) n.fail("region_max_mm", "a box corner not below region_min_mm on every axis");
  return b;
}

geometry::CameraModel camera_model(const config::Node& n) {
  geometry::CameraModel m;
  m.width = n.get<int>("image_width", 320, {16, 4096});
  m.height = n.get<int>("image_height", 240, {16, 4096});
  // Default: the thesis's KPCS20-CP1 (fx 833.57, fy 767.02 px at 640x480) scaled to the image width.
  const double scale = m.width / 640.0;
  m.fx = n.get<double>("fx", 833.57 * scale, {1.0, 1e5});
  m.fy = n.get<double>("fy", 767.02 * scale, {1.0, 1e5});
  m.cx = n.get<double>("cx", (m.width - 1) / 2.0, {0.0, double(m.width)});
  m.cy = n.get<double>("cy", (m.height - 1) / 2.0, {0.0, double(m.height)});
  m.skew = n.get<double>("skew", 0.0);
  const auto dist = n.numbers("distortion_coefficients", {0, 0, 0, 0, 0}, 5);
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
  c.rate_hz = n.get<double>("rate_hz", c.rate_hz, {0.1, 120.0});
  c.noise_std = n.get<double>("noise_std", c.noise_std, {0.0, 50.0});
  c.encoding = n.choice("encoding", c.encoding, {"jpeg", "bgr8"});
  c.jpeg_quality = n.get<int>("jpeg_quality", c.jpeg_quality, {10, 100});
  c.sensor_width = n.get<int>("sensor_width", c.sensor_width, {16, 8192});
  c.sensor_height = n.get<int>("sensor_height", c.sensor_height, {16, 8192});
  if (c.sensor_width * c.model.height != c.sensor_height * c.model.width)
    n.fail("sensor_height", "a sensor with the image's aspect ratio (the image is the sensor binned)");
  return c;
}

Mat3 rotation(const config::Node& n, const std::string& key) {
  const std::vector<double> id{1, 0, 0, 0, 1, 0, 0, 0, 1};
  const auto v = n.numbers(key, id, 9);
  Mat3 r;
  r << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  if (!(r * r.transpose()).isApprox(Mat3::Identity(), 1e-6)) n.fail(key, "an orthogonal 3x3 matrix (row-major)");
  return r;
}

Mat3 rotation_rpy_deg(const Vec3& rpy_deg) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  return (Eigen::AngleAxisd(rpy_deg.z() * kDeg, Vec3::UnitZ()) * Eigen::AngleAxisd(rpy_deg.y() * kDeg, Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy_deg.x() * kDeg, Vec3::UnitX()))
      .toRotationMatrix();
}

// {translation_mm, rpy_deg}: R = Rz(yaw) Ry(pitch) Rx(roll), as the arm model.
Placement placement_rpy(const config::Node& n, const Vec3& position, const Vec3& rpy_deg) {
  Placement p;
  p.position = vec3_mm(n, "translation_mm", position);
  const auto rpy = n.numbers("rpy_deg", {rpy_deg.x(), rpy_deg.y(), rpy_deg.z()}, 3);
  p.rotation = rotation_rpy_deg(Vec3(rpy[0], rpy[1], rpy[2]));
  return p;
}

// The simulated gripper's camera (see ArmSetup::hand_eye).
Vec3 hand_eye_position() { return {0.014, -0.009, -0.048}; }
Vec3 hand_eye_rpy_deg() { return {0.6, -0.8, 1.5}; }

}  // namespace

Placement ArmSetup::standard_hand_eye() { return {rotation_rpy_deg(hand_eye_rpy_deg()), hand_eye_position()}; }

Scenario Scenario::from_config(const config::Node& root) {
  Scenario s;
  s.name = root.required<std::string>("name");
  s.description = root.get<std::string>("description", "");
  s.seed = static_cast<uint64_t>(root.get<int64_t>("seed", 1, {0, std::numeric_limits<int64_t>::max()}));
  s.time_limit_s = root.get<double>("time_limit_s", s.time_limit_s, {1.0, 3600.0});

  const auto size = root.child("fruit_size");
  s.fruit_size.mean = size.get<double>("mean_mm", 70.5, {20.0, 200.0}) * kMm;
  s.fruit_size.std = size.get<double>("std_mm", 2.5, {0.0, 50.0}) * kMm;
  s.fruit_size.min = size.get<double>("min_mm", 65.0, {10.0, 200.0}) * kMm;
  s.fruit_size.max = size.get<double>("max_mm", 76.0, {10.0, 200.0}) * kMm;
  if (s.fruit_size.min > s.fruit_size.max) size.fail("max_mm", "a value >= min_mm");

  if (root.has("fruit")) {
    for (const auto& f : root.children("fruit")) {
      FruitSpec spec;
      spec.position = vec3(f.numbers("position_mm", 3), kMm);
      spec.diameter = f.get<double>("diameter_mm", 0.0, {0.0, 200.0}) * kMm;
      spec.sticker = f.get<double>("sticker_mm", 0.0, {0.0, 200.0}) * kMm;
      s.fruit.push_back(spec);
    }
  }
  const auto rf = root.child("random_fruit");
  s.random_fruit.count = rf.get<int>("count", 0, {0, 500});
  s.random_fruit.region = box_mm(rf, s.random_fruit.region);
  s.random_fruit.min_separation = rf.get<double>("min_separation_mm", 90.0, {0.0, 1000.0}) * kMm;

  const auto c = root.child("canopy");
  if (c.has("placed_leaves")) {
    for (const auto& l : c.children("placed_leaves")) {
      PlacedLeaf leaf;
      leaf.centre = vec3(l.numbers("centre_mm", 3), kMm);
      leaf.facing = vec3(l.numbers("facing_mm", 3), kMm);
      if ((leaf.facing - leaf.centre).norm() < 1e-6) l.fail("facing_mm", "a point away from centre_mm");
      leaf.length = l.get<double>("length_mm", 100.0, {5.0, 1000.0}) * kMm;
      leaf.width = l.get<double>("width_mm", 60.0, {5.0, 1000.0}) * kMm;
      s.canopy.placed_leaves.push_back(leaf);
    }
  }
  s.canopy.leaves = c.get<int>("leaves", 0, {0, 5000});
  s.canopy.region = box_mm(c, s.canopy.region);
  s.canopy.leaf_length_min = c.get<double>("leaf_length_min_mm", 50.0, {5.0, 500.0}) * kMm;
  s.canopy.leaf_length_max = c.get<double>("leaf_length_max_mm", 90.0, {5.0, 500.0}) * kMm;
  s.canopy.leaf_width_ratio = c.get<double>("leaf_width_ratio", 0.45, {0.05, 1.0});
  s.canopy.fruit_clearance = c.get<double>("fruit_clearance_mm", 10.0, {-100.0, 500.0}) * kMm;
  s.canopy.branches = c.get<int>("branches", 0, {0, 500});
  s.canopy.branch_radius = c.get<double>("branch_radius_mm", 12.0, {1.0, 100.0}) * kMm;
  s.canopy.trunk_base = vec3_mm(c, "trunk_base_mm", s.canopy.trunk_base);

  const auto l = root.child("lighting");
  s.lighting.sun_direction = vec3(l.numbers("sun_direction", {-0.5, -0.4, 0.3}, 3));
  if (s.lighting.sun_direction.norm() < 1e-9) l.fail("sun_direction", "a non-zero vector");
  s.lighting.sun_direction.normalize();
  s.lighting.ambient = l.get<double>("ambient", s.lighting.ambient, {0.0, 2.0});
  s.lighting.diffuse = l.get<double>("diffuse", s.lighting.diffuse, {0.0, 2.0});
  s.lighting.exposure = l.get<double>("exposure", s.lighting.exposure, {0.05, 10.0});

  const auto lk = root.child("look");
  s.look.style = lk.choice("style", s.look.style, {"flat", "field"});
  s.look.green_fraction = lk.get<double>("green_fraction", s.look.green_fraction, {0.0, 1.0});
  s.look.half_ripe_fraction = lk.get<double>("half_ripe_fraction", s.look.half_ripe_fraction, {0.0, 1.0});
  if (s.look.green_fraction + s.look.half_ripe_fraction > 1.0)
    lk.fail("half_ripe_fraction", "at most 1 - green_fraction (the rest is ripe)");
  s.look.dry_leaf_fraction = lk.get<double>("dry_leaf_fraction", s.look.dry_leaf_fraction, {0.0, 1.0});
  s.look.exposure_time_s = lk.get<double>("exposure_time_ms", s.look.exposure_time_s * 1e3, {0.0, 100.0}) * 1e-3;
  s.look.auto_exposure = lk.get<bool>("auto_exposure", s.look.auto_exposure);
  s.look.white_balance_drift = lk.get<double>("white_balance_drift", s.look.white_balance_drift, {0.0, 0.5});
  s.look.seed = s.seed;

  const auto w = root.child("wind");
  s.wind.amplitude = w.get<double>("amplitude_mm", 0.0, {0.0, 200.0}) * kMm;
  s.wind.frequency_hz = w.get<double>("frequency_hz", s.wind.frequency_hz, {0.0, 20.0});

  const auto cams = root.child("cameras");
  s.fixed_camera = camera(cams.child("fixed"));
  s.hand_camera = camera(cams.child("hand"));
  const auto ext = cams.child("fixed_extrinsic_truth");
  s.fixed_camera_truth.rotation = rotation(ext, "rotation");
  s.fixed_camera_truth.position = vec3_mm(ext, "translation_mm", Vec3::Zero());

  const auto a = root.child("arm");
  s.arm.start_tool_position = vec3_mm(a, "start_tool_position_mm", s.arm.start_tool_position);
  s.arm.start_look_at = vec3_mm(a, "start_look_at_mm", s.arm.start_look_at);
  if ((s.arm.start_look_at - s.arm.start_tool_position).norm() < 1e-3)
    a.fail("start_look_at_mm", "a point away from start_tool_position_mm");
  s.arm.reach = a.get<double>("reach_mm", 1350.0, {100.0, 5000.0}) * kMm;
  s.arm.max_linear_speed = a.get<double>("max_linear_speed", s.arm.max_linear_speed, {0.001, 5.0});
  s.arm.max_angular_speed = a.get<double>("max_angular_speed", s.arm.max_angular_speed, {0.001, 10.0});
  s.arm.max_linear_accel = a.get<double>("max_linear_accel", s.arm.max_linear_accel, {0.01, 50.0});
  s.arm.hand_eye = placement_rpy(a.child("hand_eye_truth"), hand_eye_position(), hand_eye_rpy_deg());
  s.arm.mounting = placement_rpy(a.child("mounting_truth"), Vec3::Zero(), Vec3::Zero());

  if (a.has("variants")) {
    for (const auto& v : a.children("variants")) {
      Variant var;
      var.start_tool_position = vec3(v.numbers("start_tool_position_mm", 3), kMm);
      var.start_look_at = vec3_mm(v, "start_look_at_mm", var.start_tool_position + Vec3(0, 1, 0));
      for (double i : v.numbers("fruit", std::vector<double>{})) {
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
      const auto sq = b.numbers("squares", {7, 5}, 2);
      if (sq[0] != std::floor(sq[0]) || sq[1] != std::floor(sq[1]) || sq[0] < 3 || sq[1] < 3 || sq[0] > 40 ||
          sq[1] > 40)
        b.fail("squares", "two whole numbers of squares, 3..40");
      bs.spec.squares_x = static_cast<int>(sq[0]);
      bs.spec.squares_y = static_cast<int>(sq[1]);
      bs.spec.square_m = b.get<double>("square_mm", 40.0, {5.0, 500.0}) * kMm;
      bs.spec.marker_m = b.get<double>("marker_mm", 30.0, {3.0, 500.0}) * kMm;
      if (bs.spec.marker_m >= bs.spec.square_m) b.fail("marker_mm", "smaller than square_mm");
      bs.spec.margin_m = b.get<double>("margin_mm", 20.0, {0.0, 500.0}) * kMm;
      bs.spec.dictionary = b.choice("dictionary", bs.spec.dictionary, board_dictionaries());
      bs.pose = placement_rpy(b.child("stand"), Vec3::Zero(), Vec3::Zero());
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
    s.zoom.fruit = z.get<int>("fruit", 0, {0, 10000});
    if (s.zoom.fruit >= static_cast<int>(s.fruit.size())) z.fail("fruit", "an index into the scenario's fruit list");
    s.zoom.distance = z.get<double>("distance_mm", s.zoom.distance / kMm, {20.0, 5000.0}) * kMm;
    s.zoom.rate_hz = z.get<double>("rate_hz", s.zoom.rate_hz, {0.1, 120.0});
  }

  const auto g = root.child("gripper");
  s.gripper.close_time_s = g.get<double>("close_time_s", s.gripper.close_time_s, {0.01, 10.0});
  s.gripper.open_time_s = g.get<double>("open_time_s", s.gripper.open_time_s, {0.01, 10.0});
  s.gripper.capture_radius = g.get<double>("capture_radius_mm", 22.0, {1.0, 200.0}) * kMm;
  s.gripper.capture_axial_min = g.get<double>("capture_axial_min_mm", -30.0, {-200.0, 200.0}) * kMm;
  s.gripper.capture_axial_max = g.get<double>("capture_axial_max_mm", 35.0, {-200.0, 200.0}) * kMm;
  s.gripper.knock_radius = g.get<double>("knock_radius_mm", 50.0, {1.0, 500.0}) * kMm;
  s.gripper.detach_distance = g.get<double>("detach_distance_mm", 30.0, {1.0, 500.0}) * kMm;
  s.gripper.palm_offset = g.get<double>("palm_offset_mm", 50.0, {0.0, 500.0}) * kMm;
  if (s.gripper.capture_axial_min >= s.gripper.capture_axial_max)
    g.fail("capture_axial_max_mm", "a value above capture_axial_min_mm");

  const auto ir = root.child("ir");
  s.ir.gain = ir.get<double>("gain", s.ir.gain, {1.0, 1e7});
  s.ir.offset_mm = ir.get<double>("offset_mm", s.ir.offset_mm, {0.0, 1000.0});
  s.ir.peak_range = ir.get<double>("peak_range_mm", 30.0, {0.0, 1000.0}) * kMm;
  s.ir.max_range = ir.get<double>("max_range_mm", 350.0, {1.0, 5000.0}) * kMm;
  s.ir.noise_std = ir.get<double>("noise_std", s.ir.noise_std, {0.0, 200.0});
  s.ir.rate_hz = ir.get<double>("rate_hz", s.ir.rate_hz, {1.0, 1000.0});

  const auto f = root.child("faults");
  s.faults.camera_dropout_start_s = f.get<double>("camera_dropout_start_s", -1.0);
  s.faults.camera_dropout_duration_s = f.get<double>("camera_dropout_duration_s", 0.0, {0.0, 3600.0});
  s.faults.ir_stuck_start_s = f.get<double>("ir_stuck_start_s", -1.0);
  s.faults.drive_fault_start_s = f.get<double>("drive_fault_start_s", -1.0);
  s.faults.drive_fault_joint = f.get<int>("drive_fault_joint", 1, {0, 64});
  s.faults.drive_fault_code = f.get<int>("drive_fault_code", 0x7300, {1, 0xFFFF});
  s.faults.drive_silent_start_s = f.get<double>("drive_silent_start_s", -1.0);
  s.faults.drive_silent_duration_s = f.get<double>("drive_silent_duration_s", 0.0, {0.0, 3600.0});
  s.faults.board_silent_start_s = f.get<double>("board_silent_start_s", -1.0);
  s.faults.board_silent_duration_s = f.get<double>("board_silent_duration_s", 0.0, {0.0, 3600.0});
  return s;
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
