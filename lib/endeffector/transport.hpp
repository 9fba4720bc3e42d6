// Byte-stream transports to the end-effector board. Every transport is a
// non-blocking file descriptor that the bridge watches in its poll loop;
// opening never blocks (TCP connects asynchronously, poll_open() completes it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

#include "config/config.hpp"

namespace harvest::endeffector {

class TransportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class LinkState { kClosed, kConnecting, kOpen };

struct IoResult {
  enum Status { kOk, kWouldBlock, kClosed, kError } status = kOk;
  std::size_t bytes = 0;
  std::string error;  // for kError
};

class ByteStream {
 public:
  virtual ~ByteStream() = default;
  // "tcp:127.0.0.1:4001", "serial:/dev/ttyUSB0"; used in every message about the link.
  virtual std::string describe() const = 0;
  // Start opening. Throws TransportError naming the endpoint if it fails at once.
  virtual void open() = 0;
  // While kConnecting, checks (without blocking) whether the connection completed.
  // Throws TransportError if it failed.
  virtual LinkState poll_open() = 0;
  virtual LinkState state() const = 0;
  virtual int fd() const = 0;  // -1 when closed
  virtual IoResult read(std::span<uint8_t> buffer) = 0;
  virtual IoResult write(std::span<const uint8_t> bytes) = 0;
  virtual void close() = 0;
};

// ---- serial line (libserialport) ----
// The keys of a link mapping: `transport`, then a `tcp` or `serial` mapping.
namespace transport_keys {
using config::Key;
inline constexpr config::Choice transport{"transport", "tcp", {"tcp", "serial"},
                                          "which mapping is used (the other is still checked)"};
inline constexpr Key<std::string> serial_port{.name = "port", .doc = "serial device, such as /dev/ttyUSB0",
                                              .required = true};
inline constexpr Key<int> baud{"baud", 115200, {50, 4'000'000}, "baud", "line speed"};
inline constexpr Key<int> data_bits{"data_bits", 8, {5, 8}, "", "data bits per character"};
inline constexpr config::Choice parity{"parity", "none", {"none", "odd", "even", "mark", "space"}, "parity bit"};
inline constexpr Key<int> stop_bits{"stop_bits", 1, {1, 2}, "", "stop bits"};
inline constexpr config::Choice flow_control{"flow_control", "none", {"none", "xonxoff", "rtscts", "dtrdsr"},
                                             "flow control"};
inline constexpr Key<std::string> host{"host", "127.0.0.1", {}, "",
                                       "numeric address or localhost (no DNS lookup in the loop)"};
inline constexpr Key<int> tcp_port{"port", 4001, {1, 65535}, "", "TCP port (ser2net, the simulator, the emulator)"};
}  // namespace transport_keys

struct SerialOptions {
  std::string port;  // "/dev/ttyUSB0"
  int baud = transport_keys::baud.fallback;
  int data_bits = transport_keys::data_bits.fallback;
  std::string parity{transport_keys::parity.fallback};
  int stop_bits = transport_keys::stop_bits.fallback;
  std::string flow_control{transport_keys::flow_control.fallback};

  static SerialOptions from_config(const config::Node& node);
};
std::unique_ptr<ByteStream> make_serial_stream(SerialOptions options);

// ---- TCP client (ser2net, the simulator, the board emulator) ----
struct TcpOptions {
  std::string host{transport_keys::host.fallback};
  int port = transport_keys::tcp_port.fallback;

  static TcpOptions from_config(const config::Node& node);
};
std::unique_ptr<ByteStream> make_tcp_stream(TcpOptions options);

// The configured transport: `transport: tcp|serial` with a `tcp:` or `serial:` child.
std::unique_ptr<ByteStream> make_stream_from_config(const config::Node& node);

}  // namespace harvest::endeffector
