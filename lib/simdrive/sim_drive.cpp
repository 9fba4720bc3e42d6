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
    : config_(config), send_(std::move(sink)), position_(config.initial_position) {
  const uint8_t id = config_.node_id;
  od_.add_u32(od::kDeviceType, 0, od::kDeviceTypeCia402, false);
  od_.add_u8(od::kErrorRegister, 0, 0, false);
  od_.add_string(od::kDeviceName, 0, "harvest simulated CiA 402 drive", false);
  od_.add_u16(od::kHeartbeatProducer, 0, 0, true);
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
  od_.set(od::kPositionActual, 0, static_cast<uint32_t>(position_counts()));
  sdo_ = std::make_unique<canopen::SdoServer>(id, od_, [this](const CanFrame& f) { send(f); });
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
  if (f.extended || f.remote || f.error || silent_) return;
  if (f.id == cob::kNmt && f.dlc == 2) {
    if (f.data[1] != 0 && f.data[1] != config_.node_id) return;
    switch (static_cast<canopen::NmtCommand>(f.data[0])) {
      case canopen::NmtCommand::kStart:
        nmt_ = NmtState::kOperational;
        break;
      case canopen::NmtCommand::kStop:
        nmt_ = NmtState::kStopped;
        break;
      case canopen::NmtCommand::kEnterPreOperational:
        nmt_ = NmtState::kPreOperational;
        break;
      case canopen::NmtCommand::kResetNode:
      case canopen::NmtCommand::kResetCommunication:
        nmt_ = NmtState::kBootUp;
        booted_ = false;  // boot-up message again on the next advance
        break;
    }
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
    if (!(cob_id & 0x80000000u) && (cob_id & 0x7FF) == f.id) pending_rpdo_.push_back(f);
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
  last_sync_ = now;
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
    const double accel = stopping ? config_.quick_stop_deceleration : config_.max_acceleration;
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
  if (config_.sync_timeout_us > 0 && state_ == Cia402State::kOperationEnabled && last_sync_ >= 0 &&
      now - last_sync_ > config_.sync_timeout_us)
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
  while (auto f = bus_.receive())
    for (auto& d : drives_) d->handle_frame(*f, now);
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
