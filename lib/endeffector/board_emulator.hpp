// An emulated end-effector board: speaks the line protocol exactly like the
// real board, with no I/O of its own (bytes in, bytes out, time passed in).
// The simulator embeds it behind a BoardServer and plugs in its own IR
// ray-casting and gripper physics; tests use the defaults.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "config/config.hpp"
#include "endeffector/parser.hpp"
#include "endeffector/protocol.hpp"
#include "runtime/clock.hpp"

namespace harvest::endeffector {

using rt::Micros;

struct GripperGoal {
  enum class Kind { kOpen, kClose, kMove, kStop } kind = Kind::kOpen;
  double position = 1.0;  // opening for kMove, 0 closed .. 1 open
  double force_n = 0.0;   // force limit, 0 = default
};

struct GripperReading {
  GripState state = GripState::kOpen;
  double position = 1.0;
  double force_n = 0.0;
};

// Gripper physics seen by the board. Implementations must be deterministic in `now`.
class GripperModel {
 public:
  virtual ~GripperModel() = default;
  virtual void command(const GripperGoal& goal, Micros now) = 0;
  virtual GripperReading read(Micros now) = 0;
};

// Default model: the opening moves linearly at 1/full_travel_s per second. If
// an object is set (object_position > 0), closing stops there in kHolding
// with the commanded force.
class LinearGripper final : public GripperModel {
 public:
  LinearGripper(double full_travel_s, double default_force_n)
      : travel_s_(full_travel_s), default_force_(default_force_n) {}
  void command(const GripperGoal& goal, Micros now) override;
  GripperReading read(Micros now) override;
  void set_object_position(double p) { object_ = p; }  // <= 0: nothing between the fingers

 private:
  void advance(Micros now);
  double travel_s_;
  double default_force_;
  double object_ = 0.0;
  double position_ = 1.0;
  double target_ = 1.0;
  double force_limit_ = 0.0;
  GripState state_ = GripState::kOpen;
  Micros last_ = 0;
  bool started_ = false;
};

// The board's keys (the emulator's, and the simulator's `board` mapping).
namespace board_keys {
using config::Key;
inline constexpr Key<double> ir_rate_hz{"ir_rate_hz", 100.0, {1.0, 2000.0}, "Hz", "IR range readings sent"};
inline constexpr Key<double> grip_rate_hz{"grip_rate_hz", 20.0, {1.0, 1000.0}, "Hz", "gripper states sent"};
inline constexpr Key<int32_t> ir_raw{"ir_raw", 3000, {0, 65535}, "",
                                     "IR reading when no source is plugged in"};
inline constexpr Key<double> full_travel_s{"full_travel_s", 1.0, {0.01, 60.0}, "s",
                                           "the gripper's time from fully open to closed"};
inline constexpr Key<double> default_force_n{"default_force_n", 10.0, {0.0, 1000.0}, "N",
                                             "force limit when a command says 0"};
inline constexpr Key<std::string> firmware{"firmware", "harvest-emulator-1", {}, "",
                                           "firmware version the board reports"};
}  // namespace board_keys

struct EmulatorConfig {
  double ir_rate_hz = board_keys::ir_rate_hz.fallback;
  double grip_rate_hz = board_keys::grip_rate_hz.fallback;
  int32_t ir_raw = board_keys::ir_raw.fallback;                  // when no source is plugged in
  double full_travel_s = board_keys::full_travel_s.fallback;      // default gripper: open to closed
  double default_force_n = board_keys::default_force_n.fallback;  // force limit when a command says 0
  std::string firmware{board_keys::firmware.fallback};

  static EmulatorConfig from_config(const config::Node& node);
};

class BoardEmulator {
 public:
  using IrSource = std::function<int32_t(Micros now)>;

  explicit BoardEmulator(EmulatorConfig config = {});

  void set_ir_source(IrSource source) { ir_source_ = std::move(source); }
  // A constant IR reading (replaces any IR source); for hosts that push values.
  void set_ir_raw(int32_t raw) {
    ir_source_ = [raw](Micros) { return raw; };
  }
  // Called with every valid frame from the host, before the board handles it
  // (hosts and tests observe commands; faulted boards still see them here).
  using CommandObserver = std::function<void(const Frame& frame, Micros now)>;
  void set_command_observer(CommandObserver observer) { observer_ = std::move(observer); }
  void set_gripper(std::unique_ptr<GripperModel> model) { gripper_ = std::move(model); }
  GripperModel& gripper() { return *gripper_; }

  // Bytes from the host.
  void receive(std::span<const uint8_t> bytes, Micros now);
  // Bytes for the host that are due at `now` (telemetry and answers).
  std::string produce(Micros now);
  // A new host connection: forget the partial input and start sequences again.
  void new_session(Micros now);

  // Fault injection for tests and scenarios.
  void set_silent(bool silent) { silent_ = silent; }  // a hung board: no telemetry, no answers
  void raise_fault(int32_t code, const std::string& text);

  const ParserCounters& parser_counters() const { return parser_.counters(); }
  int64_t commands_received() const { return commands_; }

 private:
  void handle(const Frame& frame, Micros now);
  void emit(Message m);

  EmulatorConfig config_;
  IrSource ir_source_;
  CommandObserver observer_;
  std::unique_ptr<GripperModel> gripper_;
  Parser parser_;
  std::string out_;
  uint16_t seq_ = 0;
  Micros next_ir_ = 0;
  Micros next_grip_ = 0;
  GripState last_state_ = GripState::kOpen;
  bool silent_ = false;
  int32_t fault_code_ = 0;
  int64_t commands_ = 0;
};

}  // namespace harvest::endeffector
