#include "canopen/master.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "can/bus_spec.hpp"
#include "config/schema.hpp"
#include "canopen/pdo.hpp"

namespace harvest::canopen {

std::string bus_from_config(const config::Node& node, const config::Key<std::string>& key_decl,
                            const std::optional<std::string>& derived_fallback) {
  const std::string key = key_decl.name;
  const auto bus = derived_fallback ? node.get(key_decl, *derived_fallback) : node.get(key_decl);
  try {
    can::parse_bus_spec(bus);
  } catch (const can::CanError& e) {
    node.fail(key, std::string("a CAN bus string: ") + e.what());
  }
  return bus;
}

MasterConfig MasterConfig::from_config(const config::Node& node) {
  namespace k = master_keys;
  MasterConfig c;
  c.sync_period = static_cast<Micros>(1e6 / node.get(k::sync_rate_hz));
  c.heartbeat_ms = static_cast<uint16_t>(node.get(k::heartbeat_ms));
  c.heartbeat_timeout = node.get(k::heartbeat_timeout_ms) * 1000;
  c.pdo_timeout = node.get(k::pdo_timeout_ms) * 1000;
  c.sdo_timeout = node.get(k::sdo_timeout_ms) * 1000;
  c.boot_timeout = node.get(k::boot_timeout_ms) * 1000;
  c.own_stall = node.get(k::own_stall_ms) * 1000;
  if (c.own_stall > 0 && c.own_stall < c.sync_period)
    node.fail("own_stall_ms", "0 (off) or at least the SYNC period (" + std::to_string(c.sync_period / 1000) + " ms)");
  if (c.heartbeat_timeout <= Micros{c.heartbeat_ms} * 1000)
    node.fail("heartbeat_timeout_ms", "a value greater than heartbeat_ms");
  c.master_node = static_cast<uint8_t>(node.get(k::master_node_id));
  c.master_heartbeat_ms = static_cast<uint16_t>(node.get(k::master_heartbeat_ms));
  c.drive_heartbeat_timeout_ms = static_cast<uint16_t>(node.get(k::drive_heartbeat_timeout_ms));
  c.drive_rpdo_timeout_ms = static_cast<uint16_t>(node.get(k::drive_rpdo_timeout_ms));
  {
    const auto choices = k::drive_communication_error.list();
    const std::string behaviour = node.get(k::drive_communication_error);
    const auto at = std::find(choices.begin(), choices.end(), behaviour) - choices.begin();
    c.drive_communication_error = static_cast<int8_t>(at == 3 ? -1 : at);
  }
  if (c.drive_heartbeat_timeout_ms <= c.master_heartbeat_ms)
    node.fail("drive_heartbeat_timeout_ms", "a value greater than master_heartbeat_ms");
  if (Micros{c.drive_rpdo_timeout_ms} * 1000 <= c.sync_period)
    node.fail("drive_rpdo_timeout_ms",
              "a value greater than the SYNC period (" + std::to_string(c.sync_period / 1000) + " ms)");
  // The drive list usually lives in its own file, shared with the simulated drives.
  // No assignment between config::Node values here: a yaml-cpp node assigned
  // to another overwrites the content of the node it refers to (the `can`
  // mapping would become the drive file).
  std::optional<config::Document> drives_doc;
  if (node.has(k::drives_file.name)) drives_doc = config::Document::load_file(node.get(k::drives_file));
  const config::Node drives_node = drives_doc ? drives_doc->root() : node;
  for (const auto& d : drives_node.children("drives")) {
    DriveConfig dc;
    dc.node_id = static_cast<uint8_t>(d.get(drive_keys::node_id));
    dc.counts_per_radian = d.get(drive_keys::counts_per_radian);
    if (std::abs(dc.counts_per_radian) < 1.0) d.fail("counts_per_radian", "a magnitude of at least 1 count per radian");
    dc.zero_offset_counts = d.get(drive_keys::zero_offset_counts);
    for (const auto& other : c.drives)
      if (other.node_id == dc.node_id) d.fail("node_id", "a node id not used by another drive");
    if (dc.node_id == c.master_node) d.fail("node_id", "a node id other than the master's (can.master_node_id)");
    c.drives.push_back(dc);
  }
  if (c.drives.empty()) drives_node.fail("drives", "a list of at least one drive");
  if (drives_doc) drives_doc->check_unused();
  return c;
}

std::vector<config::Section> MasterConfig::schema(const std::string& path, const std::string& where) {
  namespace k = master_keys;
  return {config::section(path, where, k::sync_rate_hz, k::heartbeat_ms, k::heartbeat_timeout_ms, k::pdo_timeout_ms,
                          k::sdo_timeout_ms, k::boot_timeout_ms, k::own_stall_ms, k::master_node_id, k::master_heartbeat_ms,
                          k::drive_heartbeat_timeout_ms, k::drive_rpdo_timeout_ms, k::drive_communication_error,
                          k::drives_file),
          config::section(path + ".drives[]",
                          "One per joint, in joint order; here or in `drives_file` (top-level `drives`, shared with "
                          "the simulated drives).",
                          drive_keys::node_id, drive_keys::counts_per_radian, drive_keys::zero_offset_counts)};
}

Master::Master(can::CanBus& bus, MasterConfig config)
    : bus_(bus),
      config_(std::move(config)),
      awake_(config_.own_stall),
      sdo_([this](const CanFrame& f) { send(f); }, config_.sdo_timeout),
      drives_(config_.drives.size()),
      heartbeat_armed_(config_.drives.size(), false),
      starting_(config_.drives.size(), false),
      start_began_(config_.drives.size(), 0) {}

void Master::send(const CanFrame& f) {
  try {
    bus_.send(f);
  } catch (const can::CanError& e) {
    // A refused frame shows up as missing PDOs/heartbeats downstream; log once here.
    if (events_.size() < 100) events_.push_back(std::string("CAN send failed: ") + e.what());
  }
}

void Master::start(Micros wall) {
  const Micros now = awake_.at(wall);
  now_ = now;
  phase_ = MasterPhase::kConfiguring;
  started_ = now;
  configured_ = 0;
  next_heartbeat_ = now;
  for (std::size_t i = 0; i < drives_.size(); ++i) start_drive(i, now);
}

void Master::start_drive(std::size_t i, Micros now) {
  // Pre-operational (also out of stopped), then probe, configure and start it.
  heartbeat_armed_[i] = false;
  starting_[i] = true;
  start_began_[i] = now;
  DriveStatus& d = drives_[i];
  d.seen_pdo = false;
  d.needs_startup = false;
  d.tpdo1_count = 0;
  d.syncs_at_start = sync_count_;
  d.supervise_from = now;
  d.last_heartbeat = now;
  send(nmt_frame(NmtCommand::kEnterPreOperational, config_.drives[i].node_id));
  probe(i, now);
}

void Master::fail(std::size_t i, const std::string& text) {
  phase_ = MasterPhase::kFailed;
  starting_[i] = false;
  error_ = "joint " + std::to_string(i + 1) + text;
}

void Master::probe(std::size_t i, Micros now) {
  // Check it is a CiA 402 device before writing anything to it. A drive that
  // does not answer yet (still booting, powered after us) is asked again
  // until boot_timeout has passed since its start-up began.
  const uint8_t node = config_.drives[i].node_id;
  sdo_.read(
      node, od::kDeviceType, 0,
      [this, i, node](const SdoResult& r) {
        if (!starting_[i] || phase_ == MasterPhase::kFailed) return;
        if (!r.ok && r.abort_code == sdo::kAbortTimeout && now_ - start_began_[i] < config_.boot_timeout) {
          probe(i, now_);
          return;
        }
        if (!r.ok) return fail(i, ": reading the device type failed: " + r.error);
        const uint32_t type = r.data.size() >= 4 ? get_u32(r.data.data()) : 0;
        if ((type & 0xFFFF) != 402)
          return fail(i, " (node " + std::to_string(node) + ") is not a CiA 402 drive (device type " +
                             std::to_string(type) + ")");
        configure_next(i, 0, now_);
      },
      now);
}

void Master::configure_next(std::size_t i, std::size_t step, Micros now) {
  const DriveConfig& dc = config_.drives[i];
  DriveProtection protection;
  protection.master_node = config_.master_node;
  protection.heartbeat_consumer_ms = config_.drive_heartbeat_timeout_ms;
  protection.rpdo_timeout_ms = config_.drive_rpdo_timeout_ms;
  protection.communication_error_behaviour = config_.drive_communication_error;
  protection.quick_stop_deceleration =
      static_cast<uint32_t>(std::min(4.0e9, std::round(dc.quick_stop_deceleration * std::abs(dc.counts_per_radian))));
  const auto writes = default_drive_configuration(dc.node_id, config_.heartbeat_ms, protection);
  if (step == writes.size()) {
    // Heartbeat supervision starts once the producer time is written (CiA 301:
    // a consumer watches a node from its configuration on, not before).
    drives_[i].last_heartbeat = now;
    drives_[i].supervise_from = now;
    heartbeat_armed_[i] = true;
    starting_[i] = false;
    send(nmt_frame(NmtCommand::kStart, dc.node_id));
    if (phase_ == MasterPhase::kConfiguring && ++configured_ == drives_.size()) phase_ = MasterPhase::kRunning;
    return;
  }
  const SdoWrite& w = writes[step];
  std::vector<uint8_t> bytes(w.size);
  for (std::size_t b = 0; b < w.size; ++b) bytes[b] = static_cast<uint8_t>(w.value >> (8 * b));
  sdo_.write(
      dc.node_id, w.index, w.sub, std::move(bytes),
      [this, i, step](const SdoResult& r) {
        if (!starting_[i] || phase_ == MasterPhase::kFailed) return;
        if (!r.ok) return fail(i, ": configuration failed: " + r.error);
        configure_next(i, step + 1, now_);
      },
      now);
}

int Master::index_of_node(uint8_t node) const {
  for (std::size_t i = 0; i < config_.drives.size(); ++i)
    if (config_.drives[i].node_id == node) return static_cast<int>(i);
  return -1;
}

void Master::drain(Micros wall) {
  const Micros now = awake_.at(wall);
  while (auto f = bus_.receive()) handle(*f, now);
}

void Master::handle_frame(const CanFrame& f, Micros wall) { handle(f, awake_.at(wall)); }

void Master::handle(const CanFrame& f, Micros now) {
  now_ = now;
  if (f.error || f.extended) return;  // bus errors surface through bus state and missing traffic
  if (sdo_.on_frame(f, now)) return;
  // We never receive our own frames (SocketCAN, the virtual bus and the
  // memory bus all drop them), so NMT, SYNC and anything addressed to a drive
  // (RPDO, SDO request) came from someone else.
  if (f.id == cob::kNmt || f.id == cob::kSync || f.id == cob::kHeartbeat + config_.master_node) return on_foreign(f);
  const int idx = index_of_node(node_of(f.id));
  if (idx < 0) return;
  const auto i = static_cast<std::size_t>(idx);
  DriveStatus& d = drives_[i];
  const DriveConfig& dc = config_.drives[i];
  const uint32_t fn = function_of(f.id);
  if (fn == cob::kRpdo1 || fn == cob::kRpdo1 + 0x100 || fn == cob::kRpdo1 + 0x200 || fn == cob::kRpdo1 + 0x300 ||
      fn == cob::kSdoRx) {
    on_foreign(f);
  } else if (fn == cob::kHeartbeat) {
    if (auto s = decode_heartbeat(f)) on_heartbeat(i, *s, now);
  } else if (fn == cob::kEmcy) {
    if (auto e = decode_emcy(f)) {
      d.error_code = e->error_code;
      // Before its first PDO a drive is being brought up from whatever state
      // an earlier run left it in (our NMT pre-operational can make an enabled
      // drive react with its 0x6007 option): reported, and a fault it leaves
      // is reset on the way to operation enabled, as at start.
      if (e->error_code != 0 && !d.seen_pdo)
        events_.push_back("joint " + std::to_string(i + 1) + " (node " + std::to_string(dc.node_id) + "): EMCY " +
                          describe_emcy(e->error_code) + " while starting it");
      else if (e->error_code != 0)
        latch(i, &DriveStatus::emcy, "EMCY " + describe_emcy(e->error_code));
    }
  } else if (fn == cob::kTpdo1) {
    if (auto p = decode_tpdo1(f)) on_tpdo1(i, p->statusword, p->position, now);
  } else if (fn == cob::kTpdo2) {
    if (auto v = decode_tpdo2(f)) {
      d.velocity_counts = *v;
      d.velocity = static_cast<double>(*v) / dc.counts_per_radian;
    }
  }
}

void Master::on_foreign(const CanFrame& f) {
  ++counters_["can_foreign_frames"];
  const auto cmd_name = [](uint8_t c) -> std::string {
    switch (static_cast<NmtCommand>(c)) {
      case NmtCommand::kStart:
        return "start";
      case NmtCommand::kStop:
        return "stop";
      case NmtCommand::kEnterPreOperational:
        return "enter pre-operational";
      case NmtCommand::kResetNode:
        return "reset node";
      case NmtCommand::kResetCommunication:
        return "reset communication";
    }
    return "command " + std::to_string(c);
  };
  if (f.id == cob::kSync) return latch_bus("another SYNC producer on the bus (a SYNC we did not send)");
  if (f.id != cob::kNmt) {
    const int idx = index_of_node(node_of(f.id));
    if (idx < 0) return latch_bus("another node uses the master's node id " + std::to_string(config_.master_node));
    const auto i = static_cast<std::size_t>(idx);
    if (function_of(f.id) == cob::kSdoRx) {
      // Another SDO client: a read is logged, a write (initiate download) could
      // reconfigure or command the drive behind our back.
      const uint16_t index = f.dlc >= 4 ? sdo::index_of(f) : 0;
      const uint8_t sub = f.dlc >= 4 ? sdo::subindex_of(f) : 0;
      char where[16];
      std::snprintf(where, sizeof where, "0x%04X:%02X", index, sub);
      if (f.dlc >= 1 && sdo::specifier(f) == sdo::kClientInitiateDownload)
        return latch(i, &DriveStatus::foreign, std::string("an SDO write to ") + where + " we did not send");
      if (events_.size() < 100)
        events_.push_back("joint " + std::to_string(i + 1) + ": another SDO client reads " + where);
      return;
    }
    char id[8];
    std::snprintf(id, sizeof id, "0x%03X", f.id);
    return latch(i, &DriveStatus::foreign,
                 std::string("an RPDO ") + id + " we did not send (another master on the bus)");
  }
  if (f.dlc < 2) return latch_bus("a malformed NMT frame from another master");
  const uint8_t target = f.data[1];
  const std::string what = "NMT " + cmd_name(f.data[0]) + " from another master";
  if (target == 0) {
    latch_bus(what + " for all nodes");
    for (auto& d : drives_) d.needs_startup = d.needs_startup || f.data[0] != static_cast<uint8_t>(NmtCommand::kStart);
    return;
  }
  const int idx = index_of_node(target);
  if (idx < 0) return;  // another node of that master: none of ours
  const auto i = static_cast<std::size_t>(idx);
  latch(i, &DriveStatus::foreign, what);
  if (f.data[0] != static_cast<uint8_t>(NmtCommand::kStart)) drives_[i].needs_startup = true;
}

void Master::on_heartbeat(std::size_t i, NmtState state, Micros now) {
  DriveStatus& d = drives_[i];
  const NmtState before = d.nmt;
  d.nmt = state;
  d.last_heartbeat = now;
  if (!heartbeat_armed_[i] || stopping_nodes_ || state == NmtState::kOperational) return;
  if (!d.seen_pdo && state == NmtState::kPreOperational && !d.needs_startup) {
    // A started drive that still reports pre-operational before its first
    // PDO missed the NMT start (a lost frame at start-up): start it again.
    send(nmt_frame(NmtCommand::kStart, config_.drives[i].node_id));
    return;
  }
  // Stopped, pre-operational or rebooted behind our back (another master, a
  // reset, a power cut): it no longer follows our PDOs and may have lost its
  // configuration; RESET_FAULT runs its start-up again.
  if (before != state) ++counters_["can_drive_left_operational"];
  d.needs_startup = true;
  latch(i, &DriveStatus::nmt_left,
        state == NmtState::kBootUp ? std::string("rebooted (boot-up message)")
                                   : std::string("left operational (heartbeat: ") + to_string(state) + ")");
}

void Master::on_tpdo1(std::size_t i, uint16_t statusword, int32_t position, Micros now) {
  DriveStatus& d = drives_[i];
  const DriveConfig& dc = config_.drives[i];
  const Cia402State before = d.state;
  d.statusword = statusword;
  d.state = decode_statusword(statusword);
  d.position_counts = position;
  d.position = (static_cast<double>(position) - dc.zero_offset_counts) / dc.counts_per_radian;
  d.last_tpdo = now;
  // The drive sends one TPDO1 per SYNC, and only we send SYNC: more is
  // someone else sending as the drive (forged positions or states). Counted
  // from our first SYNC since its start-up (an answer to a SYNC of an earlier
  // master may still be on its way before that).
  const int64_t syncs = sync_count_ - d.syncs_at_start;
  if (syncs > 0 && ++d.tpdo1_count > syncs)
    latch(i, &DriveStatus::foreign, "more TPDO1 frames than SYNCs (another device sends as the drive)");
  const bool faulty = d.state == Cia402State::kFault || d.state == Cia402State::kFaultReactionActive;
  const bool was_faulty = before == Cia402State::kFault || before == Cia402State::kFaultReactionActive;
  if (faulty && !d.seen_pdo) {
    // Found faulted when the master starts: bringing every drive from
    // whatever state it is in to operation enabled includes a fault
    // reset (starting the master is the operator's act). Reported, not latched.
    events_.push_back("joint " + std::to_string(i + 1) + " (node " + std::to_string(dc.node_id) + "): found in " +
                      to_string(d.state) + " at start, resetting it");
  } else if (faulty && !was_faulty) {
    latch(i, &DriveStatus::fault, std::string("drive state ") + to_string(d.state));
  } else if (d.seen_pdo && !commanded_transition(before, d.state, d.controlword, d.previous_controlword)) {
    ++counters_["can_uncommanded_state_changes"];
    latch(i, &DriveStatus::uncommanded,
          std::string("state changed from ") + to_string(before) + " to " + to_string(d.state) + " without a command");
  }
  d.seen_pdo = true;
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

void Master::latch_bus(const std::string& text) {
  if (bus_fault_.find(text) != std::string::npos) return;
  bus_fault_ = bus_fault_.empty() ? text : bus_fault_ + "; " + text;
  events_.push_back(text);
}

void Master::check_timeouts(Micros wall) { supervise(awake_.at(wall)); }

void Master::supervise(Micros now) {
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    DriveStatus& d = drives_[i];
    if (heartbeat_armed_[i] && now - d.last_heartbeat > config_.heartbeat_timeout)
      latch(i, &DriveStatus::heartbeat_lost, "heartbeat lost");
    // Until a drive's first PDO it gets boot_timeout (a busy drive or bus at
    // start); from then on the PDO watchdog is pdo_timeout.
    const Micros limit = d.seen_pdo ? config_.pdo_timeout : std::max(config_.pdo_timeout, config_.boot_timeout);
    const Micros since = d.seen_pdo ? d.last_tpdo : std::max(started_, d.supervise_from);
    if (phase_ == MasterPhase::kRunning && !starting_[i] && sync_count_ > 0 && now - since > limit)
      latch(i, &DriveStatus::pdo_lost, "no PDO from the drive");
  }
}

void Master::sync(Micros wall) {
  const Micros now = awake_.at(wall);
  if (awake_.stalls() > 0) {
    counters_["can_own_stalls"] = awake_.stalls();
    counters_["can_own_stall_max_ms"] = awake_.longest_lost_us() / 1000;
  }
  now_ = now;
  sdo_.poll(now);
  supervise(now);
  // Our own heartbeat, which every drive consumes (0x1016): it goes from the
  // start on, so a drive configured early does not time out while the others are.
  if (now >= next_heartbeat_ && phase_ != MasterPhase::kIdle) {
    send(heartbeat_frame(config_.master_node, NmtState::kOperational));
    next_heartbeat_ = std::max(next_heartbeat_ + Micros{config_.master_heartbeat_ms} * 1000, now);
  }
  if (phase_ != MasterPhase::kRunning) return;
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    DriveStatus& d = drives_[i];
    const uint8_t node = config_.drives[i].node_id;
    d.previous_controlword = d.controlword;
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
  bus_fault_.clear();
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    DriveStatus& d = drives_[i];
    // A lost heartbeat or PDO gets a fresh timeout window from the reset on:
    // a drive that came back just before it is not latched again at once,
    // one that is still silent is latched again after the timeout.
    if (d.heartbeat_lost) d.last_heartbeat = std::max(d.last_heartbeat, now_);
    if (d.pdo_lost && d.seen_pdo) d.last_tpdo = std::max(d.last_tpdo, now_);
    d.fault = d.emcy = d.heartbeat_lost = d.pdo_lost = d.nmt_left = d.uncommanded = d.foreign = false;
    d.tpdo1_count = 0;  // TPDO1 against SYNC counts afresh
    d.syncs_at_start = sync_count_;
    d.fault_text.clear();
    // Stopped or reset by someone else, or rebooted: its configuration may be
    // gone (a reset restores the drive's defaults). Run its start-up again.
    if (d.needs_startup && phase_ == MasterPhase::kRunning) {
      events_.push_back("joint " + std::to_string(i + 1) + " (node " + std::to_string(config_.drives[i].node_id) +
                        "): running its start-up again");
      ++counters_["can_drive_restarts"];
      start_drive(i, now_);
    }
  }
}

void Master::stop_nodes() {
  stopping_nodes_ = true;
  for (const auto& dc : config_.drives) send(nmt_frame(NmtCommand::kStop, dc.node_id));
}

bool Master::any_fault() const {
  if (!bus_fault_.empty()) return true;
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
