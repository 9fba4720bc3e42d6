// python-can 4.x `udp_multicast` wire format: one msgpack map per datagram
// (can/interfaces/udp_multicast/utils.py pack_message): keys timestamp,
// arbitration_id, is_extended_id, is_remote_frame, is_error_frame, channel,
// dlc, data (bin), is_fd, bitrate_switch, error_state_indicator.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "can/can_bus.hpp"

namespace harvest::can {

std::vector<uint8_t> encode_python_can(const CanFrame& frame, double timestamp_s);

// Throws CanError for anything that is not a valid classic CAN frame in this
// format (malformed msgpack, missing keys, CAN FD, dlc > 8, bad id).
CanFrame decode_python_can(const uint8_t* data, std::size_t size);

}  // namespace harvest::can
