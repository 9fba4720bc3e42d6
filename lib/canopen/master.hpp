// CANopen master for a chain of CiA 402 drives in cyclic synchronous velocity
// mode: configures each drive by SDO, starts them with NMT, then every SYNC
// period sends each drive's RPDO1 (controlword + target velocity) followed by
// SYNC, and reads back TPDO1/TPDO2, heartbeats and EMCY.
//
// It reports, and latches, what can go wrong with a drive (fault state, EMCY,
// lost heartbeat, missing PDOs); what to do about it is the caller's decision
// (lib/arm's motion safety quick-stops every drive). No threads, no clock of
// its own: the caller passes now() to every call.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "can/can_bus.hpp"
#include "canopen/cia402.hpp"
#include "canopen/sdo_client.hpp"
#include "config/config.hpp"
#include "config/schema.hpp"
#include "runtime/awake_clock.hpp"

namespace harvest::canopen {

// The CAN bus string under `key`, checked by can::parse_bus_spec: a bad one is
// a configuration error, so --check-config refuses it before anything is opened.
// A derived default (`key.derived` says which) replaces the declared one.
std::string bus_from_config(const config::Node& node, const config::Key<std::string>& key,
                            const std::optional<std::string>& derived_fallback = std::nullopt);
// The `bus` key of the processes on the arm's CAN bus (docs/can.md).
inline constexpr config::Key<std::string> kBusKey{
    "bus", "udp_multicast:239.74.163.2:43113", {}, "", "the CAN bus: socketcan:IFACE or udp_multicast[:GROUP:PORT][?ttl=N] (docs/can.md)"};

// The keys of one drive (robot_link.can.drives[i], or drives[i] of the drives file).
namespace drive_keys {
using config::Key;
inline constexpr Key<int> node_id{.name = "node_id", .range = {1, 127}, .doc = "CANopen node id", .required = true};
inline constexpr Key<double> counts_per_radian{.name = "counts_per_radian",
                                               .range = {-1e9, 1e9},
                                               .unit = "1/rad",
                                               .doc = "encoder counts per joint radian (gear included; sign = "
                                                      "direction; magnitude at least 1)",
                                               .required = true};
inline constexpr Key<int> zero_offset_counts{"zero_offset_counts", 0, {}, "counts", "counts at joint angle 0"};
}  // namespace drive_keys

struct DriveConfig {
  uint8_t node_id = 1;
  double counts_per_radian = 1.0;                                  // sign = direction
  int32_t zero_offset_counts = drive_keys::zero_offset_counts.fallback;
  double quick_stop_deceleration = 0.0;  // [rad/s^2] written to the drive (0x6085); 0 = the drive's own
};

// The keys of the `can` mapping of a robot-link configuration (docs/can.md).
namespace master_keys {
using config::Key;
inline constexpr Key<double> sync_rate_hz{"sync_rate_hz", 100.0, {1.0, 1000.0}, "Hz", "SYNC and control rate"};
inline constexpr Key<int> heartbeat_ms{"heartbeat_ms", 50, {10, 1000}, "ms",
                                       "drives' heartbeat producer time (0x1017, written by SDO)"};
inline constexpr Key<int> heartbeat_timeout_ms{"heartbeat_timeout_ms", 200, {20, 5000}, "ms",
                                               "a drive's heartbeat is lost after this (more than heartbeat_ms)"};
inline constexpr Key<int> pdo_timeout_ms{"pdo_timeout_ms", 100, {10, 5000}, "ms",
                                         "a running drive's TPDOs are lost after this"};
inline constexpr Key<int> sdo_timeout_ms{"sdo_timeout_ms", 200, {10, 5000}, "ms", "per SDO transfer"};
inline constexpr Key<int> boot_timeout_ms{"boot_timeout_ms", 2000, {0, 60000}, "ms",
                                          "a drive not answering at start is asked again this long"};
inline constexpr Key<int> master_node_id{"master_node_id", 127, {1, 127}, "",
                                         "the link's node id: its heartbeat is 0x700 + this"};
inline constexpr Key<int> master_heartbeat_ms{"master_heartbeat_ms", 10, {1, 1000}, "ms",
                                              "the link's heartbeat period, which every drive consumes"};
inline constexpr Key<int> drive_heartbeat_timeout_ms{
    "drive_heartbeat_timeout_ms", 50, {2, 10000}, "ms",
    "written to each drive (0x1016:01): the link's heartbeat lost this long, the drive quick-stops"};
inline constexpr Key<int> drive_rpdo_timeout_ms{
    "drive_rpdo_timeout_ms", 25, {1, 10000}, "ms",
    "written to each drive (0x1400:05): no RPDO1 this long, the drive quick-stops (more than a SYNC period)"};
inline constexpr config::Choice drive_communication_error{
    "drive_communication_error",
    "operational",
    {"pre_operational", "operational", "stopped", "leave"},
    "NMT state a drive goes to on a communication error (0x1029:01; leave: not written)"};
inline constexpr Key<int> own_stall_ms{
    "own_stall_ms", 30, {0, 1000}, "ms",
    "a gap longer than this between two turns of the link's loop is the link's own stall (a frozen host): only this "
    "much of it counts against the drives' heartbeat and PDO timeouts (0 = off; docs/can.md \"Own stalls\")"};
inline constexpr Key<config::Path> drives_file{
    "drives_file", "", {}, "", "file with the drive list (`drives`); absent: the list is `drives` here"};
}  // namespace master_keys

struct MasterConfig {
  std::vector<DriveConfig> drives;
  Micros sync_period = static_cast<Micros>(1e6 / master_keys::sync_rate_hz.fallback);
  uint16_t heartbeat_ms = master_keys::heartbeat_ms.fallback;  // producer time written to each drive
  Micros heartbeat_timeout = master_keys::heartbeat_timeout_ms.fallback * 1000;  // consumer: lost if silent this long
  Micros pdo_timeout = master_keys::pdo_timeout_ms.fallback * 1000;  // running drive sent no TPDO this long
  Micros sdo_timeout = master_keys::sdo_timeout_ms.fallback * 1000;
  Micros boot_timeout = master_keys::boot_timeout_ms.fallback * 1000;
  Micros own_stall = master_keys::own_stall_ms.fallback * 1000;  // 0: every gap counts against the drives
  // The master's own heartbeat (0x700 + master_node), which every drive
  // consumes, and the drives' own protection (docs/can.md).
  uint8_t master_node = master_keys::master_node_id.fallback;
  uint16_t master_heartbeat_ms = master_keys::master_heartbeat_ms.fallback;
  uint16_t drive_heartbeat_timeout_ms = master_keys::drive_heartbeat_timeout_ms.fallback;  // 0x1016
  uint16_t drive_rpdo_timeout_ms = master_keys::drive_rpdo_timeout_ms.fallback;            // 0x1400:05
  int8_t drive_communication_error = 1;  // drive: NMT state on a communication error (0x1029:01), see DriveProtection

  // Reads the `can` mapping of a robot-link configuration; the drive list is
  // `drives` there or in the file `drives_file`. Throws config::Error.
  static MasterConfig from_config(const config::Node& node);
  // Its keys, for the reference (docs/configuration.md): the mapping at `path`
  // and its drive list.
  static std::vector<config::Section> schema(const std::string& path, const std::string& where);
};

enum class MasterPhase { kIdle, kConfiguring, kRunning, kFailed };

struct DriveStatus {
  Cia402State state = Cia402State::kNotReadyToSwitchOn;
  uint16_t statusword = 0;
  bool seen_pdo = false;
  NmtState nmt = NmtState::kBootUp;
  Micros last_heartbeat = 0;
  Micros last_tpdo = 0;
  int32_t position_counts = 0;
  int32_t velocity_counts = 0;
  double position = 0.0;  // [rad]
  double velocity = 0.0;  // [rad/s]
  uint16_t controlword = 0;
  uint16_t previous_controlword = 0;  // the one sent the SYNC before
  double velocity_command = 0.0;      // [rad/s], as sent
  uint16_t error_code = 0;            // last EMCY error code
  int64_t tpdo1_count = 0;            // since this drive's start-up
  int64_t syncs_at_start = 0;         // SYNCs sent before this drive's start-up
  Micros supervise_from = 0;          // its PDO watchdog counts from here until its first TPDO
  bool needs_startup = false;         // it left operational or rebooted: RESET_FAULT re-runs its start-up
  // Latched until clear_faults():
  bool fault = false;           // drive entered Fault / fault reaction
  bool emcy = false;            // EMCY with a non-zero error code
  bool heartbeat_lost = false;  // no heartbeat within the timeout
  bool pdo_lost = false;        // no TPDO within the timeout while running
  bool nmt_left = false;        // its heartbeat says it left operational, or it rebooted
  bool uncommanded = false;     // its CiA 402 state changed without a command
  bool foreign = false;         // frames for or as this drive that we did not send
  std::string fault_text;
  bool faulted() const { return fault || emcy || heartbeat_lost || pdo_lost || nmt_left || uncommanded || foreign; }
};

class Master {
 public:
  Master(can::CanBus& bus, MasterConfig config);

  // Pre-operational, SDO configuration of every drive, then NMT start.
  void start(Micros now);
  // Reads every frame waiting on the bus.
  void drain(Micros now);
  void handle_frame(const CanFrame& frame, Micros now);
  // Once per SYNC period: supervision, state machine, RPDOs, then SYNC.
  void sync(Micros now);
  // Heartbeat and PDO timeouts only (sync() does this too); lets the caller
  // see a lost drive before it computes the commands of this period.
  void check_timeouts(Micros now);

  void set_goal(DriveGoal goal) { goal_ = goal; }
  DriveGoal goal() const { return goal_; }
  // Joint velocities [rad/s] to send; ignored for drives not in operation enabled.
  void set_velocities(const std::vector<double>& rad_per_s);
  // Clears latched faults; drives in Fault are then reset on the way to the
  // goal, and a drive that left operational or rebooted (needs_startup) has
  // its start-up (configuration by SDO, NMT start) run again.
  void clear_faults();
  // NMT stop for every drive (last act on exit, after they are disabled).
  void stop_nodes();

  MasterPhase phase() const { return phase_; }
  const std::string& error() const { return error_; }
  const std::vector<DriveStatus>& drives() const { return drives_; }
  const MasterConfig& config() const { return config_; }
  bool any_fault() const;
  // Traffic on the bus that no drive explains: another SYNC producer or NMT
  // master. Latched until clear_faults(); empty when none.
  const std::string& bus_fault() const { return bus_fault_; }
  bool all_in(Cia402State s) const;
  Micros last_sync() const { return last_sync_; }
  int64_t sync_count() const { return sync_count_; }
  // Faults latched since the last call (for logging), e.g. "joint 3 (node 3): EMCY 0x2310 current".
  std::vector<std::string> take_events();
  // Every foreign frame, drive leaving operational, state change without a
  // command and drive restart since construction (for the heartbeat counters).
  const std::map<std::string, int64_t>& counters() const { return counters_; }
  // The link's own stalls, which its watchdogs did not count against the drives.
  const rt::AwakeClock& awake() const { return awake_; }

 private:
  void start_drive(std::size_t drive, Micros now);
  void probe(std::size_t drive, Micros now);
  void configure_next(std::size_t drive, std::size_t step, Micros now);
  void fail(std::size_t drive, const std::string& text);
  void latch(std::size_t i, bool DriveStatus::*flag, const std::string& text);
  void latch_bus(const std::string& text);
  void on_heartbeat(std::size_t i, NmtState state, Micros now);
  void on_tpdo1(std::size_t i, uint16_t statusword, int32_t position, Micros now);
  void on_foreign(const CanFrame& f);
  int index_of_node(uint8_t node) const;
  void send(const CanFrame& f);
  // The public entry points take wall time and work in awake time (rt::AwakeClock) from there on.
  void handle(const CanFrame& f, Micros now);
  void supervise(Micros now);

  can::CanBus& bus_;
  MasterConfig config_;
  rt::AwakeClock awake_;
  SdoClient sdo_;
  std::vector<DriveStatus> drives_;
  std::vector<bool> heartbeat_armed_;  // per drive: configured, so its heartbeat is supervised
  std::vector<bool> starting_;         // per drive: its start-up (probe, SDO configuration) is running
  std::vector<Micros> start_began_;    // per drive: when its start-up began (boot timeout)
  MasterPhase phase_ = MasterPhase::kIdle;
  std::string error_;
  DriveGoal goal_ = DriveGoal::kDisabled;
  std::size_t configured_ = 0;
  Micros started_ = 0;
  Micros now_ = 0;  // time of the call being handled (SDO callbacks carry none)
  Micros last_sync_ = 0;
  int64_t sync_count_ = 0;
  Micros next_heartbeat_ = 0;
  bool stopping_nodes_ = false;  // stop_nodes() sent: drives leaving operational is expected
  std::string bus_fault_;
  std::vector<std::string> events_;
  std::map<std::string, int64_t> counters_;
};

}  // namespace harvest::canopen
