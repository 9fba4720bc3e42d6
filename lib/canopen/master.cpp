#include "canopen/master.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "can/bus_spec.hpp"
#include "canopen/pdo.hpp"

namespace harvest::canopen {

std::string bus_from_config(const config::Node& node, const std::string& key, const std::string& fallback) {
  const auto bus = node.get<std::string>(key, fallback);
  try {
    can::parse_bus_spec(bus);
  } catch (const can::CanError& e) {
    node.fail(key, std::string("a CAN bus string: ") + e.what());
  }
  return bus;
}

MasterConfig MasterConfig::from_config(const config::Node& node) {
  MasterConfig c;
  c.sync_period = static_cast<Micros>(1e6 / node.get<double>("sync_rate_hz", 100.0, {1.0, 1000.0}));
  c.heartbeat_ms = static_cast<uint16_t>(node.get<int>("heartbeat_ms", 50, {10, 1000}));
  c.heartbeat_timeout = node.get<int>("heartbeat_timeout_ms", 200, {20, 5000}) * 1000;
  c.pdo_timeout = node.get<int>("pdo_timeout_ms", 100, {10, 5000}) * 1000;
  c.sdo_timeout = node.get<int>("sdo_timeout_ms", 200, {10, 5000}) * 1000;
  c.boot_timeout = node.get<int>("boot_timeout_ms", 2000, {0, 60000}) * 1000;
  if (c.heartbeat_timeout <= Micros{c.heartbeat_ms} * 1000)
    node.fail("heartbeat_timeout_ms", "a value greater than heartbeat_ms");
  // The drive list usually lives in its own file, shared with the simulated drives.
  // No assignment between config::Node values here: a yaml-cpp node assigned
  // to another overwrites the content of the node it refers to (the `can`
  // mapping would become the drive file).
  std::optional<config::Document> drives_doc;
  if (node.has("drives_file")) drives_doc = config::Document::load_file(node.file_path("drives_file"));
  const config::Node drives_node = drives_doc ? drives_doc->root() : node;
  for (const auto& d : drives_node.children("drives")) {
    DriveConfig dc;
    dc.node_id = static_cast<uint8_t>(d.required<int>("node_id", {1, 127}));
    dc.counts_per_radian = d.required<double>("counts_per_radian", {-1e9, 1e9});
    if (std::abs(dc.counts_per_radian) < 1.0) d.fail("counts_per_radian", "a magnitude of at least 1 count per radian");
    dc.zero_offset_counts = d.get<int>("zero_offset_counts", 0);
    for (const auto& other : c.drives)
      if (other.node_id == dc.node_id) d.fail("node_id", "a node id not used by another drive");
    c.drives.push_back(dc);
  }
  if (c.drives.empty()) drives_node.fail("drives", "a list of at least one drive");
  if (drives_doc) drives_doc->check_unused();
  return c;
}

Master::Master(can::CanBus& bus, MasterConfig config)
    : bus_(bus),
      config_(std::move(config)),
      sdo_([this](const CanFrame& f) { send(f); }, config_.sdo_timeout),
      drives_(config_.drives.size()),
      heartbeat_armed_(config_.drives.size(), false) {}

void Master::send(const CanFrame& f) {
  try {
    bus_.send(f);
  } catch (const can::CanError& e) {
    // A refused frame shows up as missing PDOs/heartbeats downstream; log once here.
    if (events_.size() < 100) events_.push_back(std::string("CAN send failed: ") + e.what());
  }
}

void Master::start(Micros now) {
  now_ = now;
  phase_ = MasterPhase::kConfiguring;
  started_ = now;
  configure_started_ = now;
  configured_ = 0;
  heartbeat_armed_.assign(drives_.size(), false);
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    send(nmt_frame(NmtCommand::kEnterPreOperational, config_.drives[i].node_id));
    drives_[i].last_heartbeat = now;
    probe(i, now);
  }
}

void Master::probe(std::size_t i, Micros now) {
  // Check it is a CiA 402 device before writing anything to it. A drive that
  // does not answer yet (still booting, powered after us) is asked again
  // until boot_timeout has passed since start().
  const uint8_t node = config_.drives[i].node_id;
  sdo_.read(
      node, od::kDeviceType, 0,
      [this, i, node](const SdoResult& r) {
        if (phase_ != MasterPhase::kConfiguring) return;
        if (!r.ok && r.abort_code == sdo::kAbortTimeout && now_ - configure_started_ < config_.boot_timeout) {
          probe(i, now_);
          return;
        }
        if (!r.ok) {
          phase_ = MasterPhase::kFailed;
          error_ = "joint " + std::to_string(i + 1) + ": reading the device type failed: " + r.error;
          return;
        }
        const uint32_t type = r.data.size() >= 4 ? get_u32(r.data.data()) : 0;
        if ((type & 0xFFFF) != 402) {
          phase_ = MasterPhase::kFailed;
          error_ = "joint " + std::to_string(i + 1) + " (node " + std::to_string(node) +
                   ") is not a CiA 402 drive (device type " + std::to_string(type) + ")";
          return;
        }
        configure_next(i, 0, now_);
      },
      now);
}

void Master::configure_next(std::size_t i, std::size_t step, Micros now) {
  const uint8_t node = config_.drives[i].node_id;
  const auto writes = default_drive_configuration(node, config_.heartbeat_ms);
  if (step == writes.size()) {
    // Heartbeat supervision starts once the producer time is written (CiA 301:
    // a consumer watches a node from its configuration on, not before).
    drives_[i].last_heartbeat = now;
    heartbeat_armed_[i] = true;
    send(nmt_frame(NmtCommand::kStart, node));
    if (++configured_ == drives_.size()) phase_ = MasterPhase::kRunning;
    return;
  }
  const SdoWrite& w = writes[step];
  std::vector<uint8_t> bytes(w.size);
  for (std::size_t b = 0; b < w.size; ++b) bytes[b] = static_cast<uint8_t>(w.value >> (8 * b));
  sdo_.write(
      node, w.index, w.sub, std::move(bytes),
      [this, i, step](const SdoResult& r) {
        if (phase_ != MasterPhase::kConfiguring) return;
        if (!r.ok) {
          phase_ = MasterPhase::kFailed;
          error_ = "joint " + std::to_string(i + 1) + ": configuration failed: " + r.error;
          return;
        }
        configure_next(i, step + 1, now_);
      },
      now);
}

int Master::index_of_node(uint8_t node) const {
  for (std::size_t i = 0; i < config_.drives.size(); ++i)
    if (config_.drives[i].node_id == node) return static_cast<int>(i);
  return -1;
}

void Master::drain(Micros now) {
  while (auto f = bus_.receive()) handle_frame(*f, now);
}

void Master::handle_frame(const CanFrame& f, Micros now) {
  now_ = now;
  if (f.error || f.extended) return;  // bus errors surface through bus state and missing traffic
  if (sdo_.on_frame(f, now)) return;
  const int i = index_of_node(node_of(f.id));
  if (i < 0) return;
  DriveStatus& d = drives_[static_cast<std::size_t>(i)];
  const DriveConfig& dc = config_.drives[static_cast<std::size_t>(i)];
  const uint32_t fn = function_of(f.id);
  if (fn == cob::kHeartbeat) {
    if (auto s = decode_heartbeat(f)) {
      d.nmt = *s;
      d.last_heartbeat = now;
      // A started drive that still reports pre-operational before its first
      // PDO missed the NMT start (a lost frame at start-up): start it again.
      // After the first PDO a drive dropping out is a fault, not retried.
      if (phase_ == MasterPhase::kRunning && heartbeat_armed_[static_cast<std::size_t>(i)] && !d.seen_pdo &&
          *s == NmtState::kPreOperational)
        send(nmt_frame(NmtCommand::kStart, dc.node_id));
    }
  } else if (fn == cob::kEmcy) {
    if (auto e = decode_emcy(f)) {
      d.error_code = e->error_code;
      if (e->error_code != 0)
        latch(static_cast<std::size_t>(i), &DriveStatus::emcy, "EMCY " + describe_emcy(e->error_code));
    }
  } else if (fn == cob::kTpdo1) {
    if (auto p = decode_tpdo1(f)) {
      const Cia402State before = d.state;
      d.statusword = p->statusword;
      d.state = decode_statusword(p->statusword);
      d.position_counts = p->position;
      d.position = (static_cast<double>(p->position) - dc.zero_offset_counts) / dc.counts_per_radian;
      d.last_tpdo = now;
      const bool faulty = d.state == Cia402State::kFault || d.state == Cia402State::kFaultReactionActive;
      const bool was_faulty = before == Cia402State::kFault || before == Cia402State::kFaultReactionActive;
      if (faulty && !d.seen_pdo) {
        // Found faulted when the master starts: bringing every drive from
        // whatever state it is in to operation enabled includes a fault
        // reset (starting the master is the operator's act). Reported, not latched.
        events_.push_back("joint " + std::to_string(i + 1) + " (node " + std::to_string(dc.node_id) + "): found in " +
                          to_string(d.state) + " at start, resetting it");
      } else if (faulty && !was_faulty) {
        latch(static_cast<std::size_t>(i), &DriveStatus::fault, std::string("drive state ") + to_string(d.state));
      }
      d.seen_pdo = true;
    }
  } else if (fn == cob::kTpdo2) {
    if (auto v = decode_tpdo2(f)) {
      d.velocity_counts = *v;
      d.velocity = static_cast<double>(*v) / dc.counts_per_radian;
    }
  }
}

void Master::latch(std::size_t i, bool DriveStatus::*flag, const std::string& text) {
  DriveStatus& d = drives_[i];
  if (d.*flag) return;
  d.*flag = true;
  const std::string msg =
      "joint " + std::to_string(i + 1) + " (node " + std::to_string(config_.drives[i].node_id) + "): " + text;
  d.fault_text = d.fault_text.empty() ? msg : d.fault_text + "; " + msg;
  events_.push_back(msg);
}

void Master::check_timeouts(Micros now) {
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    DriveStatus& d = drives_[i];
    if (heartbeat_armed_[i] && now - d.last_heartbeat > config_.heartbeat_timeout)
      latch(i, &DriveStatus::heartbeat_lost, "heartbeat lost");
    // Until a drive's first PDO it gets boot_timeout (a busy drive or bus at
    // start); from then on the PDO watchdog is pdo_timeout.
    const Micros limit = d.seen_pdo ? config_.pdo_timeout : std::max(config_.pdo_timeout, config_.boot_timeout);
    if (phase_ == MasterPhase::kRunning && sync_count_ > 0 && now - (d.seen_pdo ? d.last_tpdo : started_) > limit)
      latch(i, &DriveStatus::pdo_lost, "no PDO from the drive");
  }
}

void Master::sync(Micros now) {
  now_ = now;
  sdo_.poll(now);
  check_timeouts(now);
  if (phase_ != MasterPhase::kRunning) return;
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    DriveStatus& d = drives_[i];
    const uint8_t node = config_.drives[i].node_id;
    d.controlword = next_controlword(d.state, goal_, d.controlword, !d.faulted());
    const bool moving = goal_ == DriveGoal::kEnabled && d.state == Cia402State::kOperationEnabled &&
                        d.controlword == controlword::kEnableOperation;
    const double v = moving ? d.velocity_command : 0.0;
    const double counts =
        std::clamp(std::round(v * config_.drives[i].counts_per_radian), double{std::numeric_limits<int32_t>::min()},
                   double{std::numeric_limits<int32_t>::max()});
    send(rpdo1_frame(node, d.controlword, static_cast<int32_t>(counts)));
  }
  send(sync_frame());
  if (sync_count_ == 0) started_ = now;
  last_sync_ = now;
  ++sync_count_;
}

void Master::set_velocities(const std::vector<double>& v) {
  for (std::size_t i = 0; i < drives_.size() && i < v.size(); ++i) drives_[i].velocity_command = v[i];
}

void Master::clear_faults() {
  for (auto& d : drives_) {
    // A lost heartbeat or PDO gets a fresh timeout window from the reset on:
    // a drive that came back just before it is not latched again at once,
    // one that is still silent is latched again after the timeout.
    if (d.heartbeat_lost) d.last_heartbeat = std::max(d.last_heartbeat, now_);
    if (d.pdo_lost && d.seen_pdo) d.last_tpdo = std::max(d.last_tpdo, now_);
    d.fault = d.emcy = d.heartbeat_lost = d.pdo_lost = false;
    d.fault_text.clear();
  }
}

void Master::stop_nodes() {
  for (const auto& dc : config_.drives) send(nmt_frame(NmtCommand::kStop, dc.node_id));
}

bool Master::any_fault() const {
  for (const auto& d : drives_)
    if (d.faulted()) return true;
  return false;
}

bool Master::all_in(Cia402State s) const {
  for (const auto& d : drives_)
    if (d.state != s || !d.seen_pdo) return false;
  return !drives_.empty();
}

std::vector<std::string> Master::take_events() { return std::exchange(events_, {}); }

}  // namespace harvest::canopen
