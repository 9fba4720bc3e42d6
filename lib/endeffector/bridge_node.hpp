// The end-effector bridge node: owns the link to the board, publishes
// IR_RANGE and GRIPPER_STATE, forwards GRIPPER_COMMAND. It never blocks: the
// link's descriptor is watched by the runner, connecting, silence detection
// and back-off run on timers, and time comes only from now().
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "endeffector/bridge_logic.hpp"
#include "endeffector/ir_calibration.hpp"
#include "endeffector/parser.hpp"
#include "endeffector/transport.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::endeffector {

struct BridgeConfig {
  std::function<std::unique_ptr<ByteStream>()> make_link;
  rt::Micros connect_timeout = 1 * rt::kSecond;
  rt::Micros silence_timeout = 200 * rt::kMilli;         // no valid frame for this long: NO_DATA
  rt::Micros reconnect_after_silence = 1 * rt::kSecond;  // ... and for this long: drop the link, reconnect
  rt::Micros backoff_initial = 100 * rt::kMilli;
  rt::Micros backoff_max = 2 * rt::kSecond;
  rt::Micros no_data_period = 100 * rt::kMilli;  // NO_DATA / DISCONNECTED repeated at this period
  double max_force_n = 40.0;
  IrCurve ir_curve = IrCurve::default_curve();
  std::string ir_channel, state_channel, command_channel, estop_channel;
  // Whom it obeys (docs/security.md): GRIPPER_COMMAND from the bound
  // controller, an e-stop clear from the operators.
  security::AuthorityConfig authority;

  static BridgeConfig from_config(const config::Node& root);
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
