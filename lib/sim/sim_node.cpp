#include "sim/sim_node.hpp"

#include <spdlog/spdlog.h>

#include <opencv2/imgcodecs.hpp>

#include "harvest/gripper_command_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "runtime/channels.hpp"

namespace harvest::sim {
namespace {

rt::Micros period(double hz) { return rt::from_seconds(1.0 / hz); }

const char* state_name(FruitState s) {
  switch (s) {
    case FruitState::kOnTree: return "on tree";
    case FruitState::kHeld: return "held";
    case FruitState::kPicked: return "picked";
    case FruitState::kKnocked: return "knocked off";
  }
  return "?";
}

Placement start_pose(const ArmSetup& a) { return {look_at_rotation(a.start_tool_position, a.start_look_at), a.start_tool_position}; }

// A fruit counts for the run when the arm can reach it and the fixed camera
// sees at least half of it at the start (the targets the issue scores).
bool counts(const Fruit& f, float visible_fraction) { return f.reachable && visible_fraction >= 0.5f; }

}  // namespace

SimConfig SimConfig::from_config(const config::Node& n) {
  SimConfig c;
  c.scenario_path = n.file_path("scenario").string();
  c.run = n.get<int>("run", 0, {0, 100000});
  c.hardware = n.choice("hardware", c.hardware, {"direct"});
  c.physics_rate_hz = n.get<double>("physics_rate_hz", c.physics_rate_hz, {10.0, 2000.0});
  c.robot_state_rate_hz = n.get<double>("robot_state_rate_hz", c.robot_state_rate_hz, {1.0, 1000.0});
  c.truth_rate_hz = n.get<double>("truth_rate_hz", c.truth_rate_hz, {0.1, 100.0});
  c.stop_when_done = n.get<bool>("stop_when_done", c.stop_when_done);
  c.done_grace_s = n.get<double>("done_grace_s", c.done_grace_s, {0.0, 600.0});
  return c;
}

SimNode::SimNode(SimConfig config, Scenario scenario)
    : rt::Node("sim"),
      config_(std::move(config)),
      scenario_(std::move(scenario)),
      scene_(scenario_),
      arm_(scenario_.arm, start_pose(scenario_.arm)),
      gripper_(scenario_.gripper),
      ir_(scenario_.ir, scenario_.seed + 3),
      fixed_renderer_(scenario_.fixed_camera.model, scenario_.fixed_camera.noise_std, scenario_.seed + 1),
      hand_renderer_(scenario_.hand_camera.model, scenario_.hand_camera.noise_std, scenario_.seed + 2) {
  // What the fixed camera sees of each fruit before anything moves decides
  // which fruit the run is scored on.
  fixed_renderer_.render(scene_, scenario_.fixed_camera_truth);
  const auto& vis = fixed_renderer_.visible_pixels();
  const auto& sil = fixed_renderer_.silhouette_pixels();
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i)
    fixed_visible_fraction_.push_back(sil[i] > 0 ? static_cast<float>(vis[i]) / static_cast<float>(sil[i]) : 0.0f);
  for (const auto& f : scene_.fruit()) last_states_.push_back(f.state);
}

double SimNode::sim_time() const { return rt::to_seconds(now() - start_); }

void SimNode::on_attach() {
  start_ = now();
  advertise(channels::kCameraFixed);
  advertise(channels::kCameraHand);
  advertise(kSimTruthChannel);
  advertise(channels::kRobotState);
  advertise(channels::kIrRange);
  advertise(channels::kGripperState);

  subscribe<robot_command_t>(channels::kRobotCommand, [this](const robot_command_t& cmd) {
    if (!arm_.command(cmd, sim_time())) count("robot_commands_refused");
  });
  subscribe<gripper_command_t>(channels::kGripperCommand, [this](const gripper_command_t& cmd) {
    if (cmd.action == gripper_command_t::ACTION_CLOSE)
      gripper_.close(sim_time());
    else if (cmd.action == gripper_command_t::ACTION_OPEN)
      gripper_.open(sim_time());
    else
      count("gripper_commands_ignored");
  });
  subscribe<harvest_status_t>(channels::kHarvestStatus, [this](const harvest_status_t& s) { on_harvest_status(s); });

  every(period(config_.physics_rate_hz), [this] { physics_tick(); });
  every(period(scenario_.fixed_camera.rate_hz), [this] { render_camera(true); });
  every(period(scenario_.hand_camera.rate_hz), [this] { render_camera(false); });
  every(period(config_.truth_rate_hz), [this] { publish_truth(); });
  every(period(config_.robot_state_rate_hz), [this] { publish_robot_state(); });
  every(period(scenario_.ir.rate_hz), [this] {
    publish_ir();
    publish_gripper_state();
  });

  int counted = 0;
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i) counted += counts(scene_.fruit()[i], fixed_visible_fraction_[i]);
  spdlog::info("scenario '{}' run {}: {} fruit, {} reachable and at least half visible to the fixed camera",
               scenario_.name, config_.run, scene_.fruit().size(), counted);
  set_health(rt::Health::kOk);
}

void SimNode::physics_tick() {
  const double t = sim_time();
  arm_.step(t);
  scene_.apply_wind(t);
  gripper_.step(t, now(), scene_, arm_.tool());
  const Placement& tool = arm_.tool();
  const Vec3 axis = tool.rotation.col(2);
  ir_range_ = ray_cast(scene_, tool.position - scenario_.gripper.palm_offset * axis, axis, scenario_.ir.max_range);
  auto& fruit = scene_.fruit();
  for (std::size_t i = 0; i < fruit.size(); ++i) {
    if (fruit[i].state == last_states_[i]) continue;
    last_states_[i] = fruit[i].state;
    count(std::string("fruit_") + state_name(fruit[i].state));
    spdlog::info("t={:.1f}s fruit {} {} (grasp offset {:.1f} mm)", t, fruit[i].id, state_name(fruit[i].state),
                 fruit[i].grasp_offset.norm() * 1e3);
  }
  check_done();
}

void SimNode::check_done() {
  if (!config_.stop_when_done) return;
  const double t = sim_time();
  if (t > scenario_.time_limit_s) {
    spdlog::warn("time limit of {:.0f} s reached; ending the run", scenario_.time_limit_s);
    publish_truth();
    ctx().request_stop(0);
    return;
  }
  bool open_left = false;
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i) {
    const Fruit& f = scene_.fruit()[i];
    if (counts(f, fixed_visible_fraction_[i]) && (f.state == FruitState::kOnTree || f.state == FruitState::kHeld))
      open_left = true;
  }
  if (open_left) {
    done_since_.reset();
    return;
  }
  if (!done_since_) done_since_ = t;
  if (t - *done_since_ >= config_.done_grace_s) {
    spdlog::info("every counted fruit is decided; ending the run");
    publish_truth();
    ctx().request_stop(0);
  }
}

image_t SimNode::make_image(const cv::Mat& bgr, const std::string& encoding, int jpeg_quality) {
  image_t img;
  img.width = bgr.cols;
  img.height = bgr.rows;
  img.roi_px[0] = img.roi_px[1] = 0.0f;
  img.roi_px[2] = static_cast<float>(bgr.cols);
  img.roi_px[3] = static_cast<float>(bgr.rows);
  img.sensor_width = bgr.cols;
  img.sensor_height = bgr.rows;
  if (encoding == "jpeg") {
    img.encoding = image_t::ENCODING_JPEG;
    img.stride = 0;
    cv::imencode(".jpg", bgr, img.data, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  } else {
    img.encoding = image_t::ENCODING_BGR8;
    img.stride = bgr.cols * 3;
    img.data.assign(bgr.data, bgr.data + bgr.total() * 3);
  }
  img.size = static_cast<int32_t>(img.data.size());
  return img;
}

void SimNode::render_camera(bool fixed) {
  const double t = sim_time();
  const auto& f = scenario_.faults;
  if (fixed && f.camera_dropout_start_s >= 0 && t >= f.camera_dropout_start_s &&
      t < f.camera_dropout_start_s + f.camera_dropout_duration_s) {
    count("fixed_frames_dropped");
    return;
  }
  const CameraSetup& cam = fixed ? scenario_.fixed_camera : scenario_.hand_camera;
  Renderer& r = fixed ? fixed_renderer_ : hand_renderer_;
  const cv::Mat& bgr = r.render(scene_, fixed ? scenario_.fixed_camera_truth : arm_.hand_camera());
  image_t img = make_image(bgr, cam.encoding, cam.jpeg_quality);
  img.header.utime = now();
  img.header.frame_id = fixed ? "camera_fixed" : "camera_hand";
  img.header.source_seq = -1;
  publish(fixed ? channels::kCameraFixed : channels::kCameraHand, img);
}

void SimNode::publish_truth() {
  sim_truth_t m;
  m.header.utime = now();
  m.header.frame_id = "base";
  m.header.source_seq = -1;
  m.scenario = scenario_.name;
  m.run = config_.run;
  to_pose(arm_.tool(), m.tool_pose);
  to_pose(arm_.hand_camera(), m.hand_camera_pose);
  m.gripper_opening = static_cast<float>(gripper_.opening());
  m.ir_true_range_m = ir_range_ ? static_cast<float>(*ir_range_) : -1.0f;
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i) {
    const Fruit& f = scene_.fruit()[i];
    sim_fruit_truth_t ft;
    ft.sim_id = f.id;
    ft.state = static_cast<int8_t>(f.state);
    for (int k = 0; k < 3; ++k) {
      ft.position_base[k] = f.position[k];
      ft.grasp_offset_base[k] = f.grasp_offset[k];
    }
    ft.diameter_m = 2.0 * f.radius;
    ft.visible_fraction_fixed = fixed_visible_fraction_[i];
    ft.reachable = f.reachable;
    ft.grasp_attempts = f.grasp_attempts;
    ft.outcome_utime = f.outcome_utime;
    m.fruits.push_back(ft);
  }
  m.num_fruits = static_cast<int32_t>(m.fruits.size());
  publish(kSimTruthChannel, m);
}

void SimNode::publish_robot_state() {
  robot_state_t s;
  s.header.utime = now();
  s.header.frame_id = "base";
  s.header.source_seq = -1;
  arm_.fill_state(s, sim_time());
  publish(channels::kRobotState, s);
}

void SimNode::publish_ir() {
  const double t = sim_time();
  int raw = ir_.sample(ir_range_);
  if (scenario_.faults.ir_stuck_start_s >= 0 && t >= scenario_.faults.ir_stuck_start_s) {
    if (ir_stuck_raw_ < 0) ir_stuck_raw_ = raw;
    raw = ir_stuck_raw_;
  }
  ir_range_t m;
  m.header.utime = now();
  m.header.frame_id = "ir";
  m.header.source_seq = -1;
  m.raw = raw;
  // The bridge's job in the field: invert the far branch of the response curve.
  const auto& ir = scenario_.ir;
  const double range = raw > 0 ? (ir.gain / raw - ir.offset_mm) * 1e-3 : ir.max_range;
  if (range >= ir.max_range) {
    m.validity = ir_range_t::TOO_FAR;
    m.range_m = static_cast<float>(ir.max_range);
  } else if (range < ir.peak_range) {
    m.validity = ir_range_t::TOO_NEAR;
    m.range_m = static_cast<float>(ir.peak_range);
  } else {
    m.validity = ir_range_t::VALID;
    m.range_m = static_cast<float>(range);
  }
  publish(channels::kIrRange, m);
}

void SimNode::publish_gripper_state() {
  gripper_state_t m;
  m.header.utime = now();
  m.header.frame_id = "gripper";
  m.header.source_seq = -1;
  switch (gripper_.phase()) {
    case GripperPhase::kOpen: m.state = gripper_state_t::STATE_OPEN; break;
    case GripperPhase::kClosing: m.state = gripper_state_t::STATE_CLOSING; break;
    case GripperPhase::kClosed: m.state = gripper_state_t::STATE_CLOSED; break;
    case GripperPhase::kHolding: m.state = gripper_state_t::STATE_HOLDING; break;
    case GripperPhase::kOpening: m.state = gripper_state_t::STATE_OPENING; break;
  }
  m.position = static_cast<float>(gripper_.opening());
  m.force_n = gripper_.phase() == GripperPhase::kHolding ? 10.0f : 0.0f;
  m.connected = true;
  m.fault_code = 0;
  publish(channels::kGripperState, m);
}

void SimNode::on_harvest_status(const harvest_status_t& s) {
  if (s.state == controller_state_) return;
  controller_state_ = s.state;
  spdlog::info("t={:.1f}s controller {} (picked {}, remaining {}, fruit {})", sim_time(), s.state, s.picked,
               s.remaining, s.current_fruit_id);
}

}  // namespace harvest::sim
