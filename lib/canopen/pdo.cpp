#include "canopen/pdo.hpp"

#include "canopen/cia402.hpp"

namespace harvest::canopen {

CanFrame rpdo1_frame(uint8_t node, uint16_t controlword, int32_t target_velocity) {
  CanFrame f;
  f.id = cob::kRpdo1 + node;
  f.dlc = 6;
  put_u16(&f.data[0], controlword);
  put_u32(&f.data[2], static_cast<uint32_t>(target_velocity));
  return f;
}

std::optional<Tpdo1> decode_tpdo1(const CanFrame& f) {
  if (function_of(f.id) != cob::kTpdo1 || f.dlc != 6 || f.remote) return std::nullopt;
  return Tpdo1{get_u16(&f.data[0]), static_cast<int32_t>(get_u32(&f.data[2]))};
}

std::optional<int32_t> decode_tpdo2(const CanFrame& f) {
  if (function_of(f.id) != cob::kTpdo2 || f.dlc != 4 || f.remote) return std::nullopt;
  return static_cast<int32_t>(get_u32(&f.data[0]));
}

std::vector<SdoWrite> default_drive_configuration(uint8_t node, uint16_t heartbeat_ms, const DriveProtection& p) {
  constexpr uint32_t kInvalid = 0x80000000u;
  const auto mapping = [](uint16_t index, uint8_t sub, uint8_t bits) {
    return (static_cast<uint32_t>(index) << 16) | (static_cast<uint32_t>(sub) << 8) | bits;
  };
  std::vector<SdoWrite> writes{
      {od::kModesOfOperation, 0, static_cast<uint8_t>(od::kModeCyclicSynchronousVelocity), 1},
      // RPDO1
      {od::kRpdoComm, 1, kInvalid | (cob::kRpdo1 + node), 4},
      {od::kRpdoComm, 2, 1, 1},
      {od::kRpdoMap, 0, 0, 1},
      {od::kRpdoMap, 1, mapping(od::kControlword, 0, 16), 4},
      {od::kRpdoMap, 2, mapping(od::kTargetVelocity, 0, 32), 4},
      {od::kRpdoMap, 0, 2, 1},
      {od::kRpdoComm, 1, cob::kRpdo1 + node, 4},
      // TPDO1
      {od::kTpdoComm, 1, kInvalid | (cob::kTpdo1 + node), 4},
      {od::kTpdoComm, 2, 1, 1},
      {od::kTpdoMap, 0, 0, 1},
      {od::kTpdoMap, 1, mapping(od::kStatusword, 0, 16), 4},
      {od::kTpdoMap, 2, mapping(od::kPositionActual, 0, 32), 4},
      {od::kTpdoMap, 0, 2, 1},
      {od::kTpdoComm, 1, cob::kTpdo1 + node, 4},
      // TPDO2
      {static_cast<uint16_t>(od::kTpdoComm + 1), 1, kInvalid | (cob::kTpdo2 + node), 4},
      {static_cast<uint16_t>(od::kTpdoComm + 1), 2, 1, 1},
      {static_cast<uint16_t>(od::kTpdoMap + 1), 0, 0, 1},
      {static_cast<uint16_t>(od::kTpdoMap + 1), 1, mapping(od::kVelocityActual, 0, 32), 4},
      {static_cast<uint16_t>(od::kTpdoMap + 1), 0, 1, 1},
      {static_cast<uint16_t>(od::kTpdoComm + 1), 1, cob::kTpdo2 + node, 4},
      // Heartbeat producer
      {od::kHeartbeatProducer, 0, heartbeat_ms, 2},
  };
  // Drive-side protection: the drive stops the joint itself when the master is gone.
  if (p.quick_stop_deceleration > 0) writes.push_back({od::kQuickStopDeceleration, 0, p.quick_stop_deceleration, 4});
  writes.push_back({od::kAbortConnectionOption, 0, static_cast<uint16_t>(p.abort_connection_option), 2});
  if (p.communication_error_behaviour >= 0)
    writes.push_back({od::kErrorBehaviour, 1, static_cast<uint8_t>(p.communication_error_behaviour), 1});
  if (p.rpdo_timeout_ms > 0) writes.push_back({od::kRpdoComm, 5, p.rpdo_timeout_ms, 2});
  if (p.master_node > 0 && p.heartbeat_consumer_ms > 0)
    writes.push_back(
        {od::kHeartbeatConsumer, 1, (static_cast<uint32_t>(p.master_node) << 16) | p.heartbeat_consumer_ms, 4});
  return writes;
}

}  // namespace harvest::canopen
