#include "endeffector/bridge_node.hpp"

#include <spdlog/spdlog.h>

#include "endeffector/nodes.hpp"
#include "runtime/channels.hpp"

namespace harvest::endeffector {

namespace {
constexpr rt::Micros kSupervisePeriod = 10 * rt::kMilli;  // connect polling and watchdog resolution
constexpr std::size_t kMaxReadPerWakeup = 16 * 1024;      // bounded, so a flooding board cannot starve LCM
constexpr std::size_t kMaxPendingOut = 4 * 1024;          // a board that takes no commands is a dead link

rt::Micros seconds(const config::Node& n, const config::Key<double>& key) { return rt::from_seconds(n.get(key)); }
}  // namespace

BridgeConfig BridgeConfig::from_config(const config::Node& root) {
  namespace k = bridge_keys;
  BridgeConfig c;
  const config::Node link = root.child("link");
  make_stream_from_config(link);  // validate the link settings now, at start-up
  c.make_link = [link] { return make_stream_from_config(link); };
  c.connect_timeout = seconds(root, k::connect_timeout_s);
  c.silence_timeout = seconds(root, k::silence_timeout_s);
  c.reconnect_after_silence = seconds(root, k::reconnect_after_silence_s);
  if (c.reconnect_after_silence < c.silence_timeout)
    root.fail("reconnect_after_silence_s", "a value >= silence_timeout_s");
  c.backoff_initial = seconds(root, k::backoff_initial_s);
  c.backoff_max = seconds(root, k::backoff_max_s);
  c.no_data_period = seconds(root, k::no_data_period_s);
  c.max_force_n = root.get(k::max_force_n);
  const std::string calib = root.get<std::string>(k::ir_calibration_file.name, std::string(k::ir_calibration_file.fallback));
  if (!calib.empty()) {
    const auto path = root.get(k::ir_calibration_file);
    try {
      auto doc = config::Document::load_file(path);
      c.ir_curve = IrCurve::from_config(doc.root());
      doc.check_unused();
    } catch (const config::Error& e) {
      root.fail("ir_calibration_file", std::string("a valid IR calibration file: ") + e.what());
    }
  }
  const config::Node ch = root.child("channels");
  c.ir_channel = ch.get(k::ir_range);
  c.state_channel = ch.get(k::gripper_state);
  c.command_channel = ch.get(k::gripper_command);
  c.estop_channel = ch.get(k::emergency_stop);
  c.authority = security::AuthorityConfig::from_config(root.child("authority"), security::AuthorityConfig::kController);
  return c;
}

std::vector<config::Section> BridgeConfig::schema() {
  namespace k = bridge_keys;
  const std::string where = "harvest-ee-bridge, config/endeffector/ee-bridge*.yaml (docs/ee-bridge.md).";
  return {config::section("ee_bridge", where, k::connect_timeout_s, k::silence_timeout_s, k::reconnect_after_silence_s,
                          k::backoff_initial_s, k::backoff_max_s, k::no_data_period_s, k::max_force_n,
                          k::ir_calibration_file),
          config::section("ee_bridge.channels", where, k::ir_range, k::gripper_state, k::gripper_command,
                          k::emergency_stop),
          config::section("ee_bridge.link", where, transport_keys::transport),
          config::section("ee_bridge.link.tcp", where, transport_keys::host, transport_keys::tcp_port),
          config::section("ee_bridge.link.serial", where, transport_keys::serial_port, transport_keys::baud,
                          transport_keys::data_bits, transport_keys::parity, transport_keys::stop_bits,
                          transport_keys::flow_control),
          security::AuthorityConfig::schema("ee_bridge.authority", where, security::AuthorityConfig::kController)};
}

BridgeNode::BridgeNode(BridgeConfig config)
    : Node("ee-bridge"),
      cfg_(std::move(config)),
      authority_(cfg_.authority, cfg_.authority.load(), clock(),
                 [this](const std::string& c, int64_t n) { count(c, n); }),
      link_(cfg_.make_link()),
      endpoint_(link_->describe()),
      gate_(cfg_.max_force_n),
      backoff_(cfg_.backoff_initial, cfg_.backoff_max) {}

BridgeNode::~BridgeNode() = default;  // the link closes itself; the runner is gone by now

void BridgeNode::on_attach() {
  advertise(cfg_.ir_channel);
  advertise(cfg_.state_channel);
  subscribe<gripper_command_t>(cfg_.command_channel, [this](const gripper_command_t& cmd) {
    if (!authority_.admit_from_controller("GRIPPER_COMMAND", cmd)) return;  // counted and logged by the gate
    const auto d = gate_.on_command(cmd);
    if (!d.frame) {
      count("commands_rejected");
      spdlog::warn("gripper command rejected: {}", d.rejection);
      return;
    }
    if (state_ != Link::kUp || silent_) {
      // Not queued: a gripper command that arrives late is worse than none.
      count("commands_dropped_no_link");
      spdlog::warn("gripper command dropped: no live link to {}", endpoint_);
      return;
    }
    send(*d.frame);
    count("commands_sent");
  });
  subscribe<emergency_stop_t>(cfg_.estop_channel, [this](const emergency_stop_t& msg) {
    if (!authority_.admit_estop(msg)) return;  // an engage always passes
    const bool was = gate_.stopped();
    const auto stop = gate_.on_emergency_stop(msg);
    if (stop && state_ == Link::kUp) send(*stop);
    if (gate_.stopped() != was)
      spdlog::warn("emergency stop {}", gate_.stopped() ? "engaged: gripper stopped" : "released");
  });
  every(kSupervisePeriod, [this] { supervise(); });
  spdlog::info("ee-bridge: {}", authority_.describe());
  set_health(rt::Health::kStarting, "connecting to " + endpoint_);
  connect();
}

void BridgeNode::connect() {
  state_ = Link::kConnecting;
  connect_started_ = now();
  had_telemetry_ = false;
  silent_ = false;
  try {
    link_->open();
    if (link_->state() == LinkState::kOpen) on_connected();
  } catch (const TransportError& e) {
    lose_link(e.what());
  }
}

void BridgeNode::on_connected() {
  state_ = Link::kUp;
  last_frame_ = now();
  at_last_frame_ = parser_.counters();
  ctx().watch_fd(link_->fd(), [this] { on_readable(); });
  count("connects");
  spdlog::info("connected to {}", endpoint_);
  send(Ping{static_cast<uint32_t>(now() & 0x7fffffff)});  // the board answers with its version
}

void BridgeNode::lose_link(const std::string& reason) {
  if (link_->fd() >= 0) ctx().unwatch_fd(link_->fd());
  link_->close();
  parser_.reset();  // a frame cut by the disconnect counts as truncated
  sync_parser_counters();
  out_.clear();
  if (state_ == Link::kUp) count("disconnects");
  if (had_telemetry_) backoff_.reset();  // a link that worked starts the back-off afresh
  had_telemetry_ = false;
  state_ = Link::kIdle;
  const rt::Micros delay = backoff_.next();
  retry_at_ = now() + delay;
  last_reason_ = reason;
  const std::string msg =
      "no link to " + endpoint_ + ": " + reason + "; retrying in " + std::to_string(delay / rt::kMilli) + " ms";
  if (health() != rt::Health::kError || health_message().rfind("no link", 0) != 0) spdlog::error("{}", msg);
  set_health(rt::Health::kError, msg);
  publish_no_data(reason);
}

void BridgeNode::supervise() {
  const rt::Micros t = now();
  switch (state_) {
    case Link::kIdle:
      if (t >= retry_at_) connect();
      break;
    case Link::kConnecting:
      try {
        if (link_->poll_open() == LinkState::kOpen)
          on_connected();
        else if (t - connect_started_ > cfg_.connect_timeout)
          lose_link("connect timed out");
      } catch (const TransportError& e) {
        lose_link(e.what());
      }
      break;
    case Link::kUp: {
      flush();
      if (state_ != Link::kUp) break;
      const rt::Micros quiet = t - last_frame_;
      if (quiet > cfg_.reconnect_after_silence) {
        count("silence_reconnects");
        lose_link("board silent for " + std::to_string(quiet / rt::kMilli) + " ms" + rejected_since_last_frame());
      } else if (quiet > cfg_.silence_timeout) {
        const std::string why = "no telemetry from " + endpoint_ + " for " + std::to_string(quiet / rt::kMilli) +
                                " ms" + rejected_since_last_frame();
        if (!silent_) {
          silent_ = true;
          count("silences");
          spdlog::warn("{}", why);
        }
        set_health(rt::Health::kDegraded, why);
        if (t - last_no_data_ >= cfg_.no_data_period) publish_no_data(why);
      }
      break;
    }
  }
  if (state_ != Link::kUp && t - last_no_data_ >= cfg_.no_data_period) publish_no_data(last_reason_);
}

void BridgeNode::on_readable() {
  uint8_t buf[2048];
  std::size_t total = 0;
  while (state_ == Link::kUp && total < kMaxReadPerWakeup) {
    const IoResult r = link_->read(buf);
    if (r.status == IoResult::kOk) {
      total += r.bytes;
      parser_.feed(std::span<const uint8_t>(buf, r.bytes), [this](const Frame& f) { on_frame(f); });
    } else if (r.status == IoResult::kWouldBlock) {
      break;
    } else {
      lose_link(r.status == IoResult::kClosed ? "connection closed by the device" : "read error: " + r.error);
      return;
    }
  }
  sync_parser_counters();
}

void BridgeNode::on_frame(const Frame& frame) {
  last_frame_ = now();
  at_last_frame_ = parser_.counters();
  if (silent_) spdlog::info("telemetry from {} is back", endpoint_);
  silent_ = false;
  had_telemetry_ = true;
  set_health(rt::Health::kOk, "connected to " + endpoint_);
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, IrSample>) {
          auto msg = make_ir_range(m.raw, cfg_.ir_curve, now());
          publish(cfg_.ir_channel, msg);
        } else if constexpr (std::is_same_v<T, Grip>) {
          last_position_ = m.position_permille * 1e-3;
          auto msg = make_gripper_state(m, fault_code_, fault_text_, now());
          publish(cfg_.state_channel, msg);
        } else if constexpr (std::is_same_v<T, Fault>) {
          fault_code_ = m.code;
          fault_text_ = m.text;
          count("board_faults");
          if (m.code != 0)
            spdlog::error("board fault {}: {}", m.code, m.text);
          else
            spdlog::info("board faults cleared");
        } else if constexpr (std::is_same_v<T, Pong>) {
          spdlog::info("board on {}: protocol {}, firmware '{}'", endpoint_, m.version, m.firmware);
        } else if constexpr (std::is_same_v<T, Ack>) {
          if (m.status != 0) {
            count("commands_refused_by_board");
            spdlog::warn("board refused command {} (status {})", m.command_seq, m.status);
          }
        } else {
          count("unexpected_frames");  // a command type coming from the board
        }
      },
      frame.message);
}

void BridgeNode::send(const Message& m) {
  out_ += encode(Frame{seq_++, m});
  flush();
}

void BridgeNode::flush() {
  while (!out_.empty() && state_ == Link::kUp) {
    const IoResult r = link_->write(std::span(reinterpret_cast<const uint8_t*>(out_.data()), out_.size()));
    if (r.status == IoResult::kOk) {
      out_.erase(0, r.bytes);
    } else if (r.status == IoResult::kWouldBlock) {
      break;
    } else {
      lose_link(r.status == IoResult::kClosed ? "connection closed by the device" : "write error: " + r.error);
      return;
    }
  }
  if (out_.size() > kMaxPendingOut) lose_link("device does not accept commands");
}

void BridgeNode::publish_no_data(const std::string& why) {
  last_no_data_ = now();
  auto ir = make_ir_no_data(now());
  publish(cfg_.ir_channel, ir);
  auto st = make_gripper_disconnected(last_position_, why, now());
  publish(cfg_.state_channel, st);
}

// Input that arrived but was not telemetry: says "wrong baud rate" (garbage) or
// "other protocol version" instead of a bare "silent".
std::string BridgeNode::rejected_since_last_frame() const {
  const ParserCounters& c = parser_.counters();
  const int64_t garbage = c.garbage_bytes - at_last_frame_.garbage_bytes;
  const int64_t rejected = c.errors() - at_last_frame_.errors();
  if (garbage == 0 && rejected == 0) return {};
  std::string s = " (since then " + std::to_string(garbage) + " bytes outside frames, " + std::to_string(rejected) +
                  " lines rejected";
  if (rejected > 0) s += ", last: " + parser_.last_error();
  return s + ")";
}

void BridgeNode::sync_parser_counters() {
  const ParserCounters& c = parser_.counters();
  const auto add = [this](const char* name, int64_t now_value, int64_t& reported) {
    if (now_value != reported) count(name, now_value - reported);
    reported = now_value;
  };
  add("frames", c.frames, reported_.frames);
  add("bad_checksum", c.bad_checksum, reported_.bad_checksum);
  add("truncated", c.truncated, reported_.truncated);
  add("garbage_bytes", c.garbage_bytes, reported_.garbage_bytes);
  add("oversize", c.oversize, reported_.oversize);
  add("unknown_version", c.unknown_version, reported_.unknown_version);
  add("unknown_type", c.unknown_type, reported_.unknown_type);
  add("bad_fields", c.bad_fields, reported_.bad_fields);
}

rt::NodeList make_ee_bridge(const config::Node& cfg, const rt::ProcessEnv& /*env*/) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<BridgeNode>(BridgeConfig::from_config(cfg)));
  return nodes;
}

}  // namespace harvest::endeffector
