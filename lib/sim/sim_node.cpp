#include "sim/sim_node.hpp"

#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstring>
#include <limits>
#include <set>

#include "can/bus_spec.hpp"
#include "endeffector/transport.hpp"
#include "geometry/transform_file.hpp"
#include "harvest/gripper_command_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/sim_truth_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/realtime.hpp"
#include "sim/ports.hpp"

namespace harvest::sim {
namespace {

rt::Micros period(double hz) { return rt::from_seconds(1.0 / hz); }

// How often what fell behind is logged while running.
constexpr rt::Micros kReportInterval = 10 * rt::kSecond;

const char* state_name(FruitState s) {
  switch (s) {
    case FruitState::kOnTree:
      return "on tree";
    case FruitState::kHeld:
      return "held";
    case FruitState::kPicked:
      return "picked";
    case FruitState::kKnocked:
      return "knocked off";
  }
  return "?";
}

// A fruit counts for the run when the arm can reach it and the fixed camera
// sees at least half of it at the start (the targets the issue scores).
bool counts(const Fruit& f, float visible_fraction) { return f.reachable && visible_fraction >= 0.5f; }

}  // namespace

SimConfig SimConfig::from_config(const config::Node& n) {
  namespace k = sim_keys;
  SimConfig c;
  c.scenario_path = n.get(k::scenario).string();
  c.run = n.get(k::run);
  c.seed = n.get(k::seed);
  c.hardware = n.get(k::hardware);
  if (c.hardware == "devices" || n.has("devices")) c.devices = DevicesConfig::from_config(n.child("devices"));
  const auto hand_eye = n.get(k::hand_eye);
  try {
    c.reported_hand_eye = to_placement(geometry::load_transform_file(hand_eye, geometry::Handedness::kProper));
  } catch (const std::exception& e) {
    n.fail("hand_eye", std::string("a readable hand-eye calibration (") + e.what() + ")");
  }
  c.physics_rate_hz = n.get(k::physics_rate_hz);
  c.robot_state_rate_hz = n.get(k::robot_state_rate_hz);
  c.truth_rate_hz = n.get(k::truth_rate_hz);
  c.stop_when_done = n.get(k::stop_when_done);
  c.done_grace_s = n.get(k::done_grace_s);
  c.render_thread = n.get(k::render_thread);
  c.late_ms = n.get(k::late_ms);
  c.realtime_priority = n.get(k::realtime_priority);
  return c;
}

std::vector<config::Section> SimConfig::schema() {
  namespace k = sim_keys;
  const std::string where = "harvest-sim, config/sim/sim*.yaml (docs/simulator.md).";
  std::vector<config::Section> out{config::section(
      "sim", where, k::scenario, k::run, k::seed, k::hardware, k::hand_eye, k::physics_rate_hz, k::robot_state_rate_hz,
      k::truth_rate_hz, k::stop_when_done, k::done_grace_s, k::render_thread, k::late_ms, k::realtime_priority)};
  for (auto& s : DevicesConfig::schema("sim.devices", where)) out.push_back(std::move(s));
  return out;
}

SimNode::SimNode(SimConfig config, Scenario scenario)
    : rt::Node("sim"),
      config_(std::move(config)),
      scenario_(std::move(scenario)),
      scene_(scenario_),
      arm_(scenario_.arm, start_tool_pose(scenario_.arm), config_.reported_hand_eye),
      gripper_(scenario_.gripper),
      ir_(scenario_.ir, scenario_.seed + 3),
      cameras_(scenario_, scene_),
      timekeeping_(rt::from_seconds(config_.late_ms * 1e-3)) {
  for (const auto& f : scene_.fruit()) last_states_.push_back(f.state);
  // Devices mode: the scenario's start pose becomes the drives' joint start
  // configuration (inverse kinematics of the true arm at its true mounting).
  if (devices_mode() && !config_.devices)
    throw std::invalid_argument("hardware 'devices' needs a devices configuration");
  if (devices_mode()) {
    const StartConfiguration start =
        start_joints(config_.devices->model, to_isometry(scenario_.arm.mounting), start_tool_pose(scenario_.arm));
    device_arm_start_ = start.q;
    if (start.tilt_rad > 1e-6)
      spdlog::warn(
          "the arm cannot take the scenario's start orientation; starting at the start position with the "
          "tool turned {:.1f} deg toward its home orientation",
          start.tilt_rad * 180.0 / 3.14159265358979323846);
  }
}

const Placement& SimNode::tool() const { return device_arm_ ? device_arm_->tool() : arm_.tool(); }

Placement SimNode::hand_camera() const { return device_arm_ ? device_arm_->hand_camera() : arm_.hand_camera(); }

double SimNode::sim_time() const { return rt::to_seconds(now() - start_); }

SimNode::~SimNode() = default;

void SimNode::every_on_time(const std::string& name, rt::Micros period, std::function<void()> step) {
  const rt::Micros first = now() + period;
  const std::size_t k = timekeeping_.add_step(name, first, period);
  ctx().add_timer(first, period, [this, k, step = std::move(step)] {
    timekeeping_.step_ran(k, now());
    step();
  });
}

void SimNode::on_attach() {
  start_ = now();
  timekeeping_.start(start_);
  worker_ = std::make_unique<RenderWorker>(
      [this](const FrameRequest& r) {
        if (render_delay_) render_delay_();
        return cameras_.render(r);
      },
      config_.render_thread);
  if (worker_->threaded()) {
    ctx().watch_fd(worker_->wake_fd(), [this] { publish_frames(); });
    // The drives stand in for hardware with its own processors: on a busy
    // machine the loop keeps their deadlines ahead of everything at normal
    // priority. The render thread, started above, stays at normal priority.
    rt::request_realtime_priority(config_.realtime_priority,
                                  "the simulated drives may miss their deadlines on a busy machine");
  }
  advertise(channels::kCameraFixed);
  advertise(channels::kCameraHand);
  advertise(kSimTruthChannel);
  if (devices_mode()) {
    attach_devices();
  } else {
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
    every_on_time("robot_state", period(config_.robot_state_rate_hz), [this] { publish_robot_state(); });
    every_on_time("ir", period(scenario_.ir.rate_hz), [this] {
      publish_ir();
      publish_gripper_state();
    });
  }
  subscribe<harvest_status_t>(channels::kHarvestStatus, [this](const harvest_status_t& s) { on_harvest_status(s); });

  every_on_time("physics", period(config_.physics_rate_hz), [this] { physics_tick(); });
  every(period(scenario_.fixed_camera.rate_hz), [this] { camera_tick(CameraId::kFixed); });
  every(period(scenario_.hand_camera.rate_hz), [this] { camera_tick(CameraId::kHand); });
  if (cameras_.has_zoom()) {
    advertise(channels::kCameraFixedZoom);
    every(period(scenario_.zoom.rate_hz), [this] { camera_tick(CameraId::kZoom); });
  }
  every(period(config_.truth_rate_hz), [this] { publish_truth(); });
  every(kReportInterval, [this] { report_timekeeping(); });

  int counted = 0;
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i)
    counted += counts(scene_.fruit()[i], cameras_.start_visible_fraction()[i]);
  spdlog::info("scenario '{}' run {} seed {}: {} fruit, {} reachable and at least half visible to the fixed camera",
               scenario_.name, config_.run, scenario_.seed, scene_.fruit().size(), counted);
  set_health(rt::Health::kOk);
}

void SimNode::attach_devices() {
  const DevicesConfig& d = *config_.devices;
  // The simulated drives are the first on their bus: anyone already there is
  // another run (a second demo or set), whose frames would cross ours.
  const can::BusSpec spec = can::parse_bus_spec(d.bus);
  if (spec.kind == can::BusSpec::Kind::kUdpMulticast && !port_free(spec.udp.port, true))
    throw std::runtime_error("virtual CAN bus " + spec.describe() + ": UDP port " + std::to_string(spec.udp.port) +
                             " is already in use on this machine (another simulator running?); give this one its "
                             "own: devices.bus, or harvest-launch --set site.can_bus=udp_multicast:GROUP:PORT?ttl=0 "
                             "(harvest-demo picks free ones)");
  bus_ = can::open_bus(d.bus);  // throws CanError with the reason
  device_arm_ = std::make_unique<DeviceArm>(*bus_, d.model, d.drives, device_arm_start_,
                                            to_isometry(scenario_.arm.mounting), scenario_.arm.hand_eye);
  if (bus_->fd() >= 0) ctx().watch_fd(bus_->fd(), [this] { device_arm_->drain(now()); });
  every_on_time("drives", d.drive_step_us, [this] {
    device_arm_->drain(now());
    device_arm_->advance(now());
  });

  board_ = std::make_unique<endeffector::BoardEmulator>(d.board);
  board_->set_gripper(std::make_unique<BoardGripper>(
      gripper_, [this](rt::Micros t) { return rt::to_seconds(t - start_); }, d.board.default_force_n));
  board_->set_ir_source([this](rt::Micros) { return ir_raw(); });
  try {
    board_server_ = std::make_unique<endeffector::BoardServer>(*board_, d.board_host, d.board_port);
  } catch (const endeffector::TransportError& e) {
    if (std::string(e.what()).find(std::strerror(EADDRINUSE)) == std::string::npos) throw;
    throw std::runtime_error(std::string(e.what()) +
                             ": another simulator (or ser2net) holds the port; give this one its own: "
                             "devices.board.port, or harvest-launch --set site.board_port=PORT (harvest-demo picks "
                             "free ones)");
  }
  ctx().watch_fd(board_server_->listen_fd(), [this] { board_server_->service(now()); });
  every_on_time("board", d.board_service_us, [this] { board_server_->service(now()); });

  const Eigen::VectorXd q = device_arm_start_ * (180.0 / 3.14159265358979323846);
  std::string joints;
  for (Eigen::Index i = 0; i < q.size(); ++i) joints += (i ? ", " : "") + fmt::format("{:.1f}", q[i]);
  spdlog::info(
      "hardware 'devices': {} simulated CiA 402 drives on {} starting at [{}] deg; end-effector board on "
      "tcp {}:{}",
      device_arm_->drives().size(), bus_->describe(), joints, d.board_host, board_server_->port());
}

void SimNode::apply_device_faults(double t) {
  const Faults& f = scenario_.faults;
  auto each_drive = [&](auto&& fn) {
    for (std::size_t i = 0; i < device_arm_->drives().size(); ++i)
      if (f.drive_fault_joint == 0 || static_cast<int>(i) + 1 == f.drive_fault_joint)
        fn(device_arm_->drives().drive(i));
  };
  if (f.drive_fault_start_s >= 0 && t >= f.drive_fault_start_s && !drive_fault_injected_) {
    drive_fault_injected_ = true;
    each_drive([&](simdrive::SimDrive& d) { d.inject_fault(static_cast<uint16_t>(f.drive_fault_code)); });
    spdlog::warn("t={:.1f}s fault injected: drive fault 0x{:04X} on joint {}", t, f.drive_fault_code,
                 f.drive_fault_joint);
  }
  auto window = [t](double start, double duration) {
    return start >= 0 && t >= start && (duration <= 0 || t < start + duration);
  };
  const bool drive_silent = window(f.drive_silent_start_s, f.drive_silent_duration_s);
  if (drive_silent != drive_silenced_) {
    drive_silenced_ = drive_silent;
    each_drive([&](simdrive::SimDrive& d) { d.set_silent(drive_silent); });
    spdlog::warn("t={:.1f}s fault injection: joint {} drive {}", t, f.drive_fault_joint,
                 drive_silent ? "silent" : "talking again");
  }
  const bool board_silent = window(f.board_silent_start_s, f.board_silent_duration_s);
  if (board_silent != board_silenced_) {
    board_silenced_ = board_silent;
    board_->set_silent(board_silent);
    spdlog::warn("t={:.1f}s fault injection: end-effector board {}", t, board_silent ? "hung" : "answering again");
  }
}

void SimNode::physics_tick() {
  const double t = sim_time();
  if (device_arm_)
    apply_device_faults(t);
  else
    arm_.step(t);
  scene_.apply_wind(t);
  gripper_.step(t, now(), scene_, tool());
  const Placement& tool = this->tool();
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
    if (counts(f, cameras_.start_visible_fraction()[i]) &&
        (f.state == FruitState::kOnTree || f.state == FruitState::kHeld))
      open_left = true;
  }
  if (open_left) {
    done_since_.reset();
    return;
  }
  if (!done_since_) done_since_ = t;
  if (t - *done_since_ < config_.done_grace_s) return;
  // A controller still at work (on a fruit that is not counted) finishes
  // first: ending the world under it drops the arm's drives and the gripper
  // board, and every process on them faults. The time limit still holds.
  if (controller_busy()) {
    if (!waiting_noted_) spdlog::info("every counted fruit is decided; waiting for the controller to finish");
    waiting_noted_ = true;
    return;
  }
  spdlog::info("every counted fruit is decided; ending the run");
  publish_truth();
  ctx().request_stop(0);
}

void SimNode::camera_tick(CameraId camera) {
  const double t = sim_time();
  const auto& f = scenario_.faults;
  if (camera == CameraId::kFixed && f.camera_dropout_start_s >= 0 && t >= f.camera_dropout_start_s &&
      t < f.camera_dropout_start_s + f.camera_dropout_duration_s) {
    count("fixed_frames_dropped");
    return;
  }
  // A zoomed view of a fruit no longer on the tree shows nothing to servo to.
  if (camera == CameraId::kZoom &&
      scene_.fruit()[static_cast<std::size_t>(scenario_.zoom.fruit)].state != FruitState::kOnTree) {
    count("zoom_frames_skipped");
    return;
  }
  // The frame shows the world as it is now, whenever it is rendered.
  FrameRequest request{camera, now(), scene_.fruit(), hand_camera(), tool()};
  if (!worker_->submit(std::move(request))) {
    count(std::string("render_dropped.") + camera_name(camera));
    timekeeping_.frame(camera, true);
    return;
  }
  if (!worker_->threaded()) publish_frames();
}

void SimNode::publish_frames() {
  for (RenderWorker::Frame& f : worker_->take()) {
    if (!f.error.empty()) {
      count(std::string("render_errors.") + camera_name(f.camera));
      int64_t suppressed = 0;
      rt::Micros since = 0;
      if (render_error_log_.admit(now(), suppressed, since))
        spdlog::error("camera {}: rendering failed: {} ({} more not logged)", camera_name(f.camera), f.error,
                      suppressed);
      continue;
    }
    timekeeping_.frame(f.camera, false);
    publish(cameras_.channel(f.camera), f.image);
  }
}

void SimNode::report_timekeeping() {
  for (const std::string& line : timekeeping_.report(now())) spdlog::warn("{}", line);
}

void SimNode::begin_shutdown() {
  if (summary_logged_) return;
  summary_logged_ = true;
  spdlog::info("{}", timekeeping_.summary(now() - start_));
}

void SimNode::publish_truth() {
  sim_truth_t m;
  m.header.utime = now();
  m.header.frame_id = "base";
  m.header.source_seq = -1;
  m.scenario = scenario_.name;
  m.run = config_.run;
  to_pose(tool(), m.tool_pose);
  to_pose(hand_camera(), m.hand_camera_pose);
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
    ft.visible_fraction_fixed = cameras_.start_visible_fraction()[i];
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

int SimNode::ir_raw() {
  const double t = sim_time();
  int raw = ir_.sample(ir_range_);
  if (scenario_.faults.ir_stuck_start_s >= 0 && t >= scenario_.faults.ir_stuck_start_s) {
    if (ir_stuck_raw_ < 0) ir_stuck_raw_ = raw;
    raw = ir_stuck_raw_;
  }
  return raw;
}

void SimNode::publish_ir() {
  const int raw = ir_raw();
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
    case GripperPhase::kOpen:
      m.state = gripper_state_t::STATE_OPEN;
      break;
    case GripperPhase::kClosing:
      m.state = gripper_state_t::STATE_CLOSING;
      break;
    case GripperPhase::kClosed:
      m.state = gripper_state_t::STATE_CLOSED;
      break;
    case GripperPhase::kHolding:
      m.state = gripper_state_t::STATE_HOLDING;
      break;
    case GripperPhase::kOpening:
      m.state = gripper_state_t::STATE_OPENING;
      break;
  }
  m.position = static_cast<float>(gripper_.opening());
  m.force_n = gripper_.phase() == GripperPhase::kHolding ? 10.0f : 0.0f;
  m.connected = true;
  m.fault_code = 0;
  publish(channels::kGripperState, m);
}

bool SimNode::controller_busy() const {
  // Resting (or never heard, or silent for 5 s: gone) is not busy.
  constexpr rt::Micros kGone = 5 * rt::kSecond;
  static const std::set<std::string> kResting{"", "IDLE", "DONE", "FAULT", "ESTOP"};
  return !kResting.count(controller_state_) && now() - controller_heard_ < kGone;
}

void SimNode::on_harvest_status(const harvest_status_t& s) {
  controller_heard_ = now();
  if (s.state == controller_state_) return;
  controller_state_ = s.state;
  spdlog::info("t={:.1f}s controller {} (picked {}, remaining {}, fruit {})", sim_time(), s.state, s.picked,
               s.remaining, s.current_fruit_id);
}

}  // namespace harvest::sim
