// The end-effector bridge node: owns the link to the board, publishes
// IR_RANGE and GRIPPER_STATE, forwards GRIPPER_COMMAND. It never blocks: the
// link's descriptor is watched by the runner, connecting, silence detection
// and back-off run on timers, and time comes only from now().
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "config/schema.hpp"
#include "endeffector/bridge_logic.hpp"
#include "endeffector/ir_calibration.hpp"
#include "endeffector/parser.hpp"
#include "endeffector/transport.hpp"
#include "runtime/channels.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::endeffector {

// The keys of config/endeffector/ee-bridge*.yaml (docs/ee-bridge.md); `link`
// is transport_keys, `authority` security::authority_keys.
namespace bridge_keys {
using config::Key;
inline constexpr Key<double> connect_timeout_s{"connect_timeout_s", 1.0, {0.01, 60.0}, "s",
                                               "a connection attempt gives up after this"};
inline constexpr Key<double> silence_timeout_s{"silence_timeout_s", 0.2, {0.02, 10.0}, "s",
                                               "no valid frame for this long: NO_DATA"};
inline constexpr Key<double> reconnect_after_silence_s{
    "reconnect_after_silence_s", 1.0, {0.05, 60.0}, "s",
    "... and for this long: drop the link and reconnect (at least silence_timeout_s)"};
inline constexpr Key<double> backoff_initial_s{"backoff_initial_s", 0.1, {0.01, 10.0}, "s",
                                               "first wait before reconnecting, doubled each failure ..."};
inline constexpr Key<double> backoff_max_s{"backoff_max_s", 2.0, {0.01, 300.0}, "s", "... up to this"};
inline constexpr Key<double> no_data_period_s{"no_data_period_s", 0.1, {0.01, 1.0}, "s",
                                              "NO_DATA / DISCONNECTED states repeated at this period"};
inline constexpr Key<double> max_force_n{"max_force_n", 40.0, {0.0, 1000.0}, "N",
                                         "grip force commands are capped at this"};
inline constexpr Key<config::Path> ir_calibration_file{
    "ir_calibration_file", "", {}, "", "IR range calibration (harvest-ir-calibrate); empty: the built-in curve"};
inline constexpr Key<std::string> ir_range{"ir_range", channels::kIrRange, {}, "", "channel of IR_RANGE"};
inline constexpr Key<std::string> gripper_state{"gripper_state", channels::kGripperState, {}, "", "channel of GRIPPER_STATE"};
inline constexpr Key<std::string> gripper_command{"gripper_command", channels::kGripperCommand, {}, "",
                                                  "channel of GRIPPER_COMMAND"};
inline constexpr Key<std::string> emergency_stop{"emergency_stop", channels::kEmergencyStop, {}, "",
                                                 "channel of EMERGENCY_STOP"};
}  // namespace bridge_keys

struct BridgeConfig {
  std::function<std::unique_ptr<ByteStream>()> make_link;
  rt::Micros connect_timeout = rt::from_seconds(bridge_keys::connect_timeout_s.fallback);
  rt::Micros silence_timeout = rt::from_seconds(bridge_keys::silence_timeout_s.fallback);
  rt::Micros reconnect_after_silence = rt::from_seconds(bridge_keys::reconnect_after_silence_s.fallback);
  rt::Micros backoff_initial = rt::from_seconds(bridge_keys::backoff_initial_s.fallback);
  rt::Micros backoff_max = rt::from_seconds(bridge_keys::backoff_max_s.fallback);
  rt::Micros no_data_period = rt::from_seconds(bridge_keys::no_data_period_s.fallback);
  double max_force_n = bridge_keys::max_force_n.fallback;
  IrCurve ir_curve = IrCurve::default_curve();
  std::string ir_channel, state_channel, command_channel, estop_channel;
  // Whom it obeys (docs/security.md): GRIPPER_COMMAND from the bound
  // controller, an e-stop clear from the operators.
  security::AuthorityConfig authority;

  static BridgeConfig from_config(const config::Node& root);
  static std::vector<config::Section> schema();
};

class BridgeNode final : public rt::Node {
 public:
  explicit BridgeNode(BridgeConfig config);
  ~BridgeNode() override;

 private:
  enum class Link { kIdle, kConnecting, kUp };

  void on_attach() override;
  void supervise();
  void connect();
  void on_connected();
  void on_readable();
  void lose_link(const std::string& reason);
  void on_frame(const Frame& frame);
  void send(const Message& m);
  void flush();
  void publish_no_data(const std::string& why);
  void sync_parser_counters();
  std::string rejected_since_last_frame() const;

  BridgeConfig cfg_;
  security::Authority authority_;
  std::unique_ptr<ByteStream> link_;
  std::string endpoint_;
  Parser parser_;
  ParserCounters reported_;  // parser counters already added to the node's counters
  CommandGate gate_;
  Backoff backoff_;
  Link state_ = Link::kIdle;
  rt::Micros connect_started_ = 0;
  rt::Micros retry_at_ = 0;
  rt::Micros last_frame_ = 0;
  ParserCounters at_last_frame_;  // parser counters at the last good frame (what came since is rejected input)
  rt::Micros last_no_data_ = 0;
  bool had_telemetry_ = false;  // on this connection
  bool silent_ = false;
  std::string last_reason_;
  std::string out_;  // bytes the link did not take yet
  uint16_t seq_ = 0;
  int32_t fault_code_ = 0;
  std::string fault_text_;
  double last_position_ = 0.0;
};

}  // namespace harvest::endeffector
