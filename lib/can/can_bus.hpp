// CAN transport: classic CAN 2.0 frames over SocketCAN (field) or a virtual
// bus on UDP multicast that is wire-compatible with python-can's
// `udp_multicast` interface (tests, simulation). See docs/can.md.
//
// A bus is non-blocking: receive() returns nothing when no frame is waiting,
// and fd() is readable when one is, so a node can watch it with
// Context::watch_fd in its single-threaded loop.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace harvest::can {

class CanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CanFrame {
  uint32_t id = 0;  // 11-bit (or 29-bit if extended) arbitration id
  bool extended = false;
  bool remote = false;
  bool error = false;  // an error frame (SocketCAN error report), id holds the error class
  uint8_t dlc = 0;     // 0..8
  std::array<uint8_t, 8> data{};
  int64_t timestamp_us = 0;  // receive time from the transport, microseconds since the epoch; 0 if unknown

  bool operator==(const CanFrame& o) const {
    return id == o.id && extended == o.extended && remote == o.remote && error == o.error && dlc == o.dlc &&
           data == o.data;
  }
};

// Accept a frame when (frame.id & mask) == (id & mask), as SocketCAN does.
struct CanFilter {
  uint32_t id = 0;
  uint32_t mask = 0;
  bool matches(const CanFrame& f) const { return (f.id & mask) == (id & mask); }
};

// Controller state as far as the transport can tell.
enum class BusState { kActive, kWarning, kPassive, kBusOff };
const char* to_string(BusState s);

class CanBus {
 public:
  virtual ~CanBus() = default;
  // Queue one frame; throws CanError if the transport refuses it (bus off,
  // buffer full, interface down). Never blocks.
  virtual void send(const CanFrame& frame) = 0;
  // The next received frame that passes the filters, if any. Error frames are
  // always delivered (they update state()). Never blocks.
  virtual std::optional<CanFrame> receive() = 0;
  // Readable when receive() may have a frame.
  virtual int fd() const = 0;
  // Empty list = accept everything.
  virtual void set_filters(const std::vector<CanFilter>& filters) = 0;
  virtual BusState state() const = 0;
  virtual std::string describe() const = 0;
};

// Opens a bus from a configuration string (parse_bus_spec, can/bus_spec.hpp):
//   socketcan:<interface>                            e.g. socketcan:can0
//   udp_multicast[:<group>[:<port>]][?ttl=<0..255>]  e.g. udp_multicast:239.74.163.2:43113?ttl=0 (TTL 0 by default)
// Throws CanError with a message saying what is wrong.
std::unique_ptr<CanBus> open_bus(const std::string& spec);

std::string to_string(const CanFrame& frame);  // "0x181 [8] 01 02 ..." for logs

}  // namespace harvest::can
