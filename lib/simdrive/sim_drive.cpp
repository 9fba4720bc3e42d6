#include "simdrive/sim_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace harvest::simdrive {

namespace od = canopen::od;
namespace sdo = canopen::sdo;
namespace cob = canopen::cob;
using can::CanFrame;

namespace {
uint32_t u32(const std::vector<uint8_t>& v) {
  uint32_t x = 0;
  for (std::size_t i = 0; i < v.size() && i < 4; ++i) x |= static_cast<uint32_t>(v[i]) << (8 * i);
  return x;
}
}  // namespace

SimDrive::SimDrive(SimDriveConfig config, std::function<void(const CanFrame&)> sink)
    : config_(config), send_(std::move(sink)), position_(config.initial_position), awake_(config.own_stall_us) {
  build_dictionary();
}

void SimDrive::build_dictionary() {
  // The object dictionary at power-on (and after an NMT reset): the defaults
  // of a drive nobody has configured yet.
  od_ = canopen::ObjectDictionary();
  const uint8_t id = config_.node_id;
  od_.add_u32(od::kDeviceType, 0, od::kDeviceTypeCia402, false);
  od_.add_u8(od::kErrorRegister, 0, 0, false);
  od_.add_string(od::kDeviceName, 0, "harvest simulated CiA 402 drive", false);
  od_.add_u16(od::kHeartbeatProducer, 0, 0, true);
  od_.add_u8(od::kHeartbeatConsumer, 0, 1, false);
  od_.add_u32(od::kHeartbeatConsumer, 1, 0, true);  // (producer node << 16) | time [ms]; 0 = off
  od_.add_u8(od::kErrorBehaviour, 0, 1, false);
  od_.add_u8(od::kErrorBehaviour, 1, 0, true, [](const std::vector<uint8_t>& v) {
    return v[0] <= 2 ? 0u : sdo::kAbortValueRange;
  });
  // PDO communication and mapping parameters; mapped objects must exist and fit in 8 bytes.
  const auto mappable = [this](const std::vector<uint8_t>& v) -> uint32_t {
    const uint32_t m = u32(v);
    const uint16_t index = static_cast<uint16_t>(m >> 16);
    const uint8_t sub = static_cast<uint8_t>(m >> 8);
    const uint8_t bits = static_cast<uint8_t>(m);
    if (!od_.has(index, sub) || (bits != 8 && bits != 16 && bits != 32)) return sdo::kAbortNotMappable;
    return 0;
  };
  for (uint16_t n = 0; n < 2; ++n) {
    od_.add_u32(static_cast<uint16_t>(od::kRpdoComm + n), 1, 0x80000000u | (cob::kRpdo1 + 0x100u * n + id), true);
    od_.add_u8(static_cast<uint16_t>(od::kRpdoComm + n), 2, 0xFF, true);
    od_.add_u16(static_cast<uint16_t>(od::kRpdoComm + n), 5, 0, true);  // event timer = deadline [ms]; 0 = off
    od_.add_u32(static_cast<uint16_t>(od::kTpdoComm + n), 1, 0x80000000u | (cob::kTpdo1 + 0x100u * n + id), true);
    od_.add_u8(static_cast<uint16_t>(od::kTpdoComm + n), 2, 0xFF, true);
    const auto count_ok = [](const std::vector<uint8_t>& v) { return v[0] <= 4 ? 0u : sdo::kAbortValueRange; };
    od_.add_u8(static_cast<uint16_t>(od::kRpdoMap + n), 0, 0, true, count_ok);
    od_.add_u8(static_cast<uint16_t>(od::kTpdoMap + n), 0, 0, true, count_ok);
    for (uint8_t s = 1; s <= 4; ++s) {
      od_.add_u32(static_cast<uint16_t>(od::kRpdoMap + n), s, 0, true, mappable);
      od_.add_u32(static_cast<uint16_t>(od::kTpdoMap + n), s, 0, true, mappable);
    }
  }
  od_.add_u16(od::kAbortConnectionOption, 0, 1, true, [](const std::vector<uint8_t>& v) {
    const auto code = static_cast<int16_t>(v[0] | (v[1] << 8));
    return code >= 0 && code <= 3 ? 0u : sdo::kAbortValueRange;  // no manufacturer-specific codes here
  });
  od_.add_u16(od::kErrorCode, 0, 0, false);
  od_.add_u16(od::kControlword, 0, 0, true);
  od_.add_u16(od::kStatusword, 0, canopen::encode_statusword(state_), false);
  od_.add_u16(od::kQuickStopOption, 0, 6, false);
  od_.add_u8(od::kModesOfOperation, 0, 0, true, [](const std::vector<uint8_t>& v) {
    return static_cast<int8_t>(v[0]) == od::kModeCyclicSynchronousVelocity ? 0u : sdo::kAbortValueRange;
  });
  od_.add_u8(od::kModesOfOperationDisplay, 0, 0, false);
  od_.add_u32(od::kPositionActual, 0, 0, false);
  od_.add_u32(od::kVelocityActual, 0, 0, false);
  od_.add_u32(od::kTargetVelocity, 0, 0, true);
  od_.add_u32(od::kQuickStopDeceleration, 0,
              static_cast<uint32_t>(std::min(4.0e9, std::round(config_.quick_stop_deceleration *
                                                               std::abs(config_.counts_per_radian)))),
              true, [](const std::vector<uint8_t>& v) { return u32(v) > 0 ? 0u : sdo::kAbortValueRange; });
  od_.set(od::kPositionActual, 0, static_cast<uint32_t>(position_counts()));
  sdo_ = std::make_unique<canopen::SdoServer>(id, od_, [this](const CanFrame& f) { send(f); });
}

void SimDrive::reset(bool application) {
  // NMT reset: the drive reboots its communication (and with reset node its
  // application: power stage off, the joint held by its brake) and comes
  // back with its defaults, as if nobody had configured it.
  // Reset communication keeps the application's objects (0x6000 on).
  std::vector<std::pair<uint16_t, uint32_t>> kept;
  if (!application)
    for (const uint16_t index : {od::kAbortConnectionOption, od::kControlword, od::kModesOfOperation,
                                 od::kModesOfOperationDisplay, od::kQuickStopDeceleration, od::kTargetVelocity})
      kept.emplace_back(index, od_.get(index, 0));
  build_dictionary();
  for (const auto& [index, value] : kept) od_.set(index, 0, value);
  if (application) {
    set_state(Cia402State::kSwitchOnDisabled);
    velocity_ = target_velocity_ = 0.0;
    last_controlword_ = 0;
  } else {
    od_.set(od::kStatusword, 0, canopen::encode_statusword(state_));
  }
  pending_rpdo_.clear();
  master_heartbeat_ = last_rpdo_ = -1;
  master_heartbeat_lost_ = rpdo_late_ = false;
  nmt_ = NmtState::kBootUp;
  booted_ = false;  // boot-up message again on the next advance
}

void SimDrive::abort_connection(uint16_t fault_code) {
  const auto option = static_cast<int16_t>(od_.get(od::kAbortConnectionOption, 0));
  if (state_ != Cia402State::kOperationEnabled) return;
  if (option == 1) {
    inject_fault(fault_code);
  } else if (option == 2) {
    set_state(Cia402State::kSwitchOnDisabled);
  } else if (option == 3) {
    set_state(Cia402State::kQuickStopActive);
    target_velocity_ = 0.0;
  }
}

void SimDrive::communication_error(uint16_t emcy_code) {
  // CiA 301: an EMCY, then the error behaviour (0x1029:01); CiA 402: the
  // abort connection option (0x6007) acts on a drive that is producing torque.
  canopen::Emcy e;
  e.error_code = emcy_code;
  e.error_register = 0x11;  // generic + communication
  od_.set(od::kErrorRegister, 0, e.error_register);
  send(canopen::emcy_frame(config_.node_id, e));
  abort_connection(emcy_code);
  const auto behaviour = od_.get(od::kErrorBehaviour, 1);
  if (behaviour == 0 && nmt_ == NmtState::kOperational) nmt_ = NmtState::kPreOperational;
  if (behaviour == 2) nmt_ = NmtState::kStopped;
}

void SimDrive::send(const CanFrame& f) {
  if (!silent_) send_(f);
}

int32_t SimDrive::position_counts() const {
  const double c = std::round(position_ * config_.counts_per_radian) + config_.zero_offset_counts;
  return static_cast<int32_t>(
      std::clamp(c, double{std::numeric_limits<int32_t>::min()}, double{std::numeric_limits<int32_t>::max()}));
}

void SimDrive::set_state(Cia402State s) {
  state_ = s;
  od_.set(od::kStatusword, 0, canopen::encode_statusword(s));
}

void SimDrive::handle_frame(const CanFrame& f, Micros now) {
  // A drive still initialising hears nothing: it answers no SDO before its boot-up message. (The
  // sim-drives process drains its socket before its first step; a drive that answered then was
  // configured by the master and announced a "reboot" right after.)
  if (f.extended || f.remote || f.error || silent_ || !booted_) return;
  if (f.id == cob::kNmt && f.dlc == 2) {
    if (f.data[1] != 0 && f.data[1] != config_.node_id) return;
    // RPDO deadline monitoring starts again with the first RPDO in the new state.
    last_rpdo_ = -1;
    rpdo_late_ = false;
    switch (static_cast<canopen::NmtCommand>(f.data[0])) {
      case canopen::NmtCommand::kStart:
        nmt_ = NmtState::kOperational;
        break;
      // Leaving operational while producing torque is a lost connection
      // (CiA 402 0x6007 names NMT stopped and the resets; pre-operational is
      // treated alike: a drive there ignores its RPDOs, nothing could stop it).
      case canopen::NmtCommand::kStop:
        abort_connection(0x8100);
        nmt_ = NmtState::kStopped;
        break;
      case canopen::NmtCommand::kEnterPreOperational:
        abort_connection(0x8100);
        nmt_ = NmtState::kPreOperational;
        break;
      case canopen::NmtCommand::kResetNode:
        reset(true);
        break;
      case canopen::NmtCommand::kResetCommunication:
        abort_connection(0x8100);
        reset(false);
        break;
    }
    return;
  }
  // Heartbeat consumer (CiA 301): monitoring starts with the first heartbeat
  // of the configured producer, in any state but stopped... and stopped too,
  // as most drives do.
  const uint32_t consumer = od_.get(od::kHeartbeatConsumer, 1);
  if ((consumer & 0xFFFF) != 0 && f.id == cob::kHeartbeat + ((consumer >> 16) & 0x7F) && f.dlc >= 1) {
    master_heartbeat_ = awake_.at(now);
    master_heartbeat_lost_ = false;
    return;
  }
  if (nmt_ == NmtState::kStopped) return;
  if (f.id == cob::kSync && f.dlc == 0) {
    on_sync(now);
    return;
  }
  if (sdo_->on_frame(f)) return;
  if (nmt_ != NmtState::kOperational) return;
  for (uint16_t n = 0; n < 2; ++n) {
    const uint32_t cob_id = od_.get(static_cast<uint16_t>(od::kRpdoComm + n), 1);
    if (!(cob_id & 0x80000000u) && (cob_id & 0x7FF) == f.id) {
      pending_rpdo_.push_back(f);
      if (n == 0) {
        last_rpdo_ = awake_.at(now);
        rpdo_late_ = false;
      }
    }
  }
}

void SimDrive::apply_rpdo(const CanFrame& f) {
  for (uint16_t n = 0; n < 2; ++n) {
    const uint32_t cob_id = od_.get(static_cast<uint16_t>(od::kRpdoComm + n), 1);
    if ((cob_id & 0x80000000u) || (cob_id & 0x7FF) != f.id) continue;
    const auto map = static_cast<uint16_t>(od::kRpdoMap + n);
    std::size_t offset = 0;
    for (uint8_t s = 1; s <= od_.get(map, 0); ++s) {
      const uint32_t m = od_.get(map, s);
      const std::size_t len = (m & 0xFF) / 8;
      if (offset + len > f.dlc) return;  // too short for the mapping: ignore the PDO
      uint32_t v = 0;
      for (std::size_t b = 0; b < len; ++b) v |= static_cast<uint32_t>(f.data[offset + b]) << (8 * b);
      od_.set(static_cast<uint16_t>(m >> 16), static_cast<uint8_t>(m >> 8), v);
      offset += len;
    }
  }
}

void SimDrive::on_sync(Micros now) {
  advance(now);
  last_sync_ = awake_.at(now);
  for (const auto& f : pending_rpdo_) apply_rpdo(f);
  pending_rpdo_.clear();
  if (nmt_ == NmtState::kOperational) {
    const auto cw = static_cast<uint16_t>(od_.get(od::kControlword, 0));
    if (cw != last_controlword_ || state_ != Cia402State::kOperationEnabled) {
      set_state(canopen::apply_controlword(state_, cw, last_controlword_));
      last_controlword_ = cw;
    }
    const bool csv = static_cast<int8_t>(od_.get(od::kModesOfOperation, 0)) == od::kModeCyclicSynchronousVelocity;
    od_.set(od::kModesOfOperationDisplay, 0, od_.get(od::kModesOfOperation, 0));
    target_velocity_ = (csv && state_ == Cia402State::kOperationEnabled)
                           ? static_cast<int32_t>(od_.get(od::kTargetVelocity, 0)) / config_.counts_per_radian
                           : 0.0;
    send_tpdos();
  }
}

void SimDrive::send_tpdos() {
  od_.set(od::kPositionActual, 0, static_cast<uint32_t>(position_counts()));
  od_.set(od::kVelocityActual, 0,
          static_cast<uint32_t>(static_cast<int32_t>(std::round(velocity_ * config_.counts_per_radian))));
  for (uint16_t n = 0; n < 2; ++n) {
    const uint32_t cob_id = od_.get(static_cast<uint16_t>(od::kTpdoComm + n), 1);
    if (cob_id & 0x80000000u) continue;
    const auto map = static_cast<uint16_t>(od::kTpdoMap + n);
    CanFrame f;
    f.id = cob_id & 0x7FF;
    std::size_t offset = 0;
    for (uint8_t s = 1; s <= od_.get(map, 0); ++s) {
      const uint32_t m = od_.get(map, s);
      const std::size_t len = (m & 0xFF) / 8;
      if (offset + len > 8) break;
      const uint32_t v = od_.get(static_cast<uint16_t>(m >> 16), static_cast<uint8_t>(m >> 8));
      for (std::size_t b = 0; b < len; ++b) f.data[offset + b] = static_cast<uint8_t>(v >> (8 * b));
      offset += len;
    }
    f.dlc = static_cast<uint8_t>(offset);
    send(f);
  }
}

void SimDrive::advance(Micros now) {
  if (!booted_) {
    booted_ = true;
    nmt_ = NmtState::kPreOperational;
    send(canopen::heartbeat_frame(config_.node_id, NmtState::kBootUp));
    next_heartbeat_ = now;
  }
  if (last_advance_ < 0) last_advance_ = now;
  const double dt = static_cast<double>(now - last_advance_) * 1e-6;
  last_advance_ = now;
  if (dt > 0) {
    const bool stopping = state_ == Cia402State::kQuickStopActive || state_ == Cia402State::kFaultReactionActive;
    const bool enabled = state_ == Cia402State::kOperationEnabled;
    const double goal = enabled ? target_velocity_ : 0.0;
    const double accel =
        stopping ? static_cast<double>(od_.get(od::kQuickStopDeceleration, 0)) / std::abs(config_.counts_per_radian)
                 : config_.max_acceleration;
    // Without torque (disabled states) the brake holds the joint at once.
    if (!enabled && !stopping) {
      velocity_ = 0.0;
    } else {
      const double dv = std::clamp(goal - velocity_, -accel * dt, accel * dt);
      const double v0 = velocity_;
      velocity_ += dv;
      position_ += 0.5 * (v0 + velocity_) * dt;
    }
    if (state_ == Cia402State::kFaultReactionActive && velocity_ == 0.0) set_state(Cia402State::kFault);
  }
  // The master's heartbeat (0x1016) and the RPDO deadline (0x1400:05), each
  // reported once per loss (re-armed by the next heartbeat or RPDO).
  const Micros awake = awake_.at(now);
  const Micros consumer_time = Micros{od_.get(od::kHeartbeatConsumer, 1) & 0xFFFF} * 1000;
  if (consumer_time > 0 && master_heartbeat_ >= 0 && !master_heartbeat_lost_ &&
      awake - master_heartbeat_ > consumer_time) {
    master_heartbeat_lost_ = true;
    communication_error(0x8130);
  }
  const Micros deadline = Micros{od_.get(od::kRpdoComm, 5)} * 1000;
  if (deadline > 0 && last_rpdo_ >= 0 && !rpdo_late_ && nmt_ == NmtState::kOperational &&
      awake - last_rpdo_ > deadline) {
    rpdo_late_ = true;
    communication_error(0x8250);
  }
  if (config_.sync_timeout_us > 0 && state_ == Cia402State::kOperationEnabled && last_sync_ >= 0 &&
      awake - last_sync_ > config_.sync_timeout_us)
    inject_fault(0x8100);  // communication: the master is gone (or the cable is cut)
  const Micros period = Micros{od_.get(od::kHeartbeatProducer, 0)} * 1000;
  if (period > 0 && now >= next_heartbeat_) {
    if (heartbeat_enabled_) send(canopen::heartbeat_frame(config_.node_id, nmt_));
    next_heartbeat_ = now + period;
  }
}

void SimDrive::inject_fault(uint16_t error_code) {
  od_.set(od::kErrorCode, 0, error_code);
  od_.set(od::kErrorRegister, 0, 0x01);
  const bool moving = state_ == Cia402State::kOperationEnabled || state_ == Cia402State::kQuickStopActive;
  set_state(moving ? Cia402State::kFaultReactionActive : Cia402State::kFault);
  canopen::Emcy e;
  e.error_code = error_code;
  e.error_register = 0x01;
  send(canopen::emcy_frame(config_.node_id, e));
}

SimDriveSet::SimDriveSet(can::CanBus& bus, const std::vector<SimDriveConfig>& configs) : bus_(bus) {
  for (const auto& c : configs)
    drives_.push_back(std::make_unique<SimDrive>(c, [this](const CanFrame& f) { bus_.send(f); }));
}

void SimDriveSet::drain(Micros now) {
  while (auto f = bus_.receive()) {
    last_frame_ = f->timestamp_us > 0 ? f->timestamp_us : now;
    for (auto& d : drives_) d->handle_frame(*f, now);
  }
}

void SimDriveSet::advance(Micros now) {
  for (auto& d : drives_) d->advance(now);
}

std::vector<double> SimDriveSet::positions() const {
  std::vector<double> out;
  for (const auto& d : drives_) out.push_back(d->position());
  return out;
}

}  // namespace harvest::simdrive
