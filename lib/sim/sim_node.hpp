// The simulator as a node: owns the scene, renders both cameras on its timers,
// runs the gripper/IR physics, and publishes ground truth (SIM_TRUTH).
//
// Hardware mode "direct": the simulator also stands in for the robot link
// (follows ROBOT_COMMAND with a Cartesian arm, publishes ROBOT_STATE) and for
// the end-effector bridge (follows GRIPPER_COMMAND, publishes IR_RANGE and
// GRIPPER_STATE), so perception and the servo controller run against it with
// no device protocol in between.
//
// Hardware mode "devices": the simulator plays only the hardware. The arm is
// simulated CiA 402 drives on the CAN bus (its true pose is the forward
// kinematics of the drives' joint positions), the end-effector board is served
// on its TCP port, and the field's harvest-robot-link and harvest-ee-bridge
// publish ROBOT_STATE, IR_RANGE and GRIPPER_STATE (see sim/devices.hpp).
//
// Threads (render_thread): the loop owns the scene, the physics, the drives
// and the board, and publishes everything; at each camera tick it hands a
// snapshot to the render thread (sim/render_worker.hpp), which owns the
// renderers, and publishes the frames it gets back. A camera still rendering
// its previous frame drops the tick. How late the loop's steps run and how
// many frames were dropped is logged while running and at the end
// (sim/timekeeping.hpp).
#pragma once

#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "endeffector/board_server.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/node.hpp"
#include "sim/cartesian_arm.hpp"
#include "sim/devices.hpp"
#include "sim/hand.hpp"
#include "sim/render_worker.hpp"
#include "sim/scene.hpp"
#include "sim/timekeeping.hpp"

namespace harvest::sim {

inline constexpr const char* kSimTruthChannel = "SIM_TRUTH";  // sim_truth_t

// The keys of config/sim/sim*.yaml (docs/simulator.md).
namespace sim_keys {
using config::Key;
inline constexpr Key<config::Path> scenario{.name = "scenario", .doc = "the scenario file (config/scenarios/)",
                                            .required = true};
inline constexpr Key<int> run{"run", 0, {0, 100000}, "", "which of the scenario's runs"};
inline constexpr Key<int64_t> seed{"seed", -1, {-1, std::numeric_limits<int64_t>::max()}, "",
                                   ">= 0: draw the scenario with this seed instead of its own (tree benchmarks)"};
inline constexpr config::Choice hardware{"hardware", "direct", {"direct", "devices"},
                                         "the arm and board directly, or as drives on a CAN bus and a TCP board"};
inline constexpr Key<config::Path> hand_eye{"hand_eye", "config/cameras/hand_eye.yaml", {}, "",
                                            "hardware direct: the camera-in-hand calibration for ROBOT_STATE"};
inline constexpr Key<double> physics_rate_hz{"physics_rate_hz", 100.0, {10.0, 2000.0}, "Hz", "physics steps"};
inline constexpr Key<double> robot_state_rate_hz{"robot_state_rate_hz", 100.0, {1.0, 1000.0}, "Hz",
                                                 "ROBOT_STATE published (hardware direct)"};
inline constexpr Key<double> truth_rate_hz{"truth_rate_hz", 20.0, {0.1, 100.0}, "Hz", "SIM_TRUTH published"};
inline constexpr Key<bool> stop_when_done{"stop_when_done", true, {}, "", "end the process when the run is over"};
inline constexpr Key<double> done_grace_s{"done_grace_s", 2.0, {0.0, 600.0}, "s",
                                          "keep running this long after the last fruit is decided"};
inline constexpr Key<bool> render_thread{"render_thread", true, {}, "",
                                         "render the cameras on their own thread, so the physics and the drives keep "
                                         "time (false: on the loop)"};
inline constexpr Key<double> late_ms{"late_ms", 5.0, {0.1, 1000.0}, "ms",
                                     "a physics, drive, board or state step this much behind its time counts as late"};
inline constexpr Key<int> realtime_priority{
    "realtime_priority", 0, {0, 99}, "",
    "SCHED_FIFO priority of the loop (drives, board, physics, ROBOT_STATE) when the cameras render on their own "
    "thread, which stays at normal priority (0: normal; needs root or CAP_SYS_NICE, refused: a warning)"};
}  // namespace sim_keys

struct SimConfig {
  std::string scenario_path;
  int run = sim_keys::run.fallback;
  int64_t seed = sim_keys::seed.fallback;  // >= 0: draw the scenario with this seed instead of its own
  std::string hardware{sim_keys::hardware.fallback};  // see docs/simulator.md
  std::optional<DevicesConfig> devices;  // hardware "devices": drives, bus and board
  // Hardware "direct": the software's camera-in-hand calibration (the file the
  // robot link's arm model reads), for the camera pose in the ROBOT_STATE the
  // simulator publishes in the robot link's place.
  Placement reported_hand_eye;
  double physics_rate_hz = sim_keys::physics_rate_hz.fallback;
  double robot_state_rate_hz = sim_keys::robot_state_rate_hz.fallback;
  double truth_rate_hz = sim_keys::truth_rate_hz.fallback;
  bool stop_when_done = sim_keys::stop_when_done.fallback;  // end the process when the run is over
  double done_grace_s = sim_keys::done_grace_s.fallback;    // after the last fruit is decided
  // Live runs render on a thread of their own. Replays (logical time) must
  // render on the loop, or frames would land at unrepeatable times.
  bool render_thread = sim_keys::render_thread.fallback;
  double late_ms = sim_keys::late_ms.fallback;
  int realtime_priority = sim_keys::realtime_priority.fallback;  // the loop's SCHED_FIFO priority (render thread on)

  static SimConfig from_config(const config::Node& node);
  static std::vector<config::Section> schema();
};

class SimNode final : public rt::Node {
 public:
  SimNode(SimConfig config, Scenario scenario);
  ~SimNode() override;

  const Scene& scene() const { return scene_; }
  const Gripper& gripper() const { return gripper_; }
  const CartesianArm& arm() const { return arm_; }
  bool devices_mode() const { return config_.hardware == "devices"; }
  // The arm's true tool and hand camera poses (world frame), in either mode.
  const Placement& tool() const;
  Placement hand_camera() const;

  const Timekeeping& timekeeping() const { return timekeeping_; }
  // Tests: runs on the render thread before each frame (a slow renderer).
  void set_render_delay(std::function<void()> delay) { render_delay_ = std::move(delay); }

  // Logs the run's timekeeping summary (once).
  void begin_shutdown() override;

 protected:
  void on_attach() override;

 private:
  double sim_time() const;  // [s] since the node started
  void physics_tick();
  // A periodic step whose lateness is kept (timekeeping_).
  void every_on_time(const std::string& name, rt::Micros period, std::function<void()> step);
  // A camera tick: a snapshot for the render thread (or a frame rendered here).
  void camera_tick(CameraId camera);
  void publish_frames();
  void report_timekeeping();
  void publish_truth();
  void publish_robot_state();
  void publish_ir();
  void publish_gripper_state();
  void on_harvest_status(const harvest_status_t& status);
  void check_done();
  void attach_devices();
  void apply_device_faults(double t);
  int ir_raw();

  SimConfig config_;
  Scenario scenario_;
  Scene scene_;
  CartesianArm arm_;
  Eigen::VectorXd device_arm_start_;  // joint start configuration (devices mode)
  std::unique_ptr<can::CanBus> bus_;
  std::unique_ptr<DeviceArm> device_arm_;
  std::unique_ptr<endeffector::BoardEmulator> board_;
  std::unique_ptr<endeffector::BoardServer> board_server_;
  bool drive_fault_injected_ = false, drive_silenced_ = false, board_silenced_ = false;
  Gripper gripper_;
  IrSensor ir_;
  // The renderers and their scene: the render thread's alone once the worker
  // starts (the loop reads only what was fixed at construction).
  SimCameras cameras_;
  std::function<void()> render_delay_;
  std::unique_ptr<RenderWorker> worker_;
  Timekeeping timekeeping_;
  bool summary_logged_ = false;
  rt::LogLimiter render_error_log_{10 * rt::kSecond};
  std::optional<double> ir_range_;
  int ir_stuck_raw_ = -1;
  rt::Micros start_ = 0;
  // The controller's state and when it was last heard from: a run is not
  // ended under a controller still at work.
  std::string controller_state_;
  rt::Micros controller_heard_ = 0;
  bool waiting_noted_ = false;
  bool controller_busy() const;
  std::vector<FruitState> last_states_;
  std::optional<double> done_since_;
};

}  // namespace harvest::sim
