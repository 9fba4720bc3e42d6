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
struct SerialOptions {
  std::string port;  // "/dev/ttyUSB0"
  int baud = 115200;
  int data_bits = 8;
  std::string parity = "none";  // none, odd, even, mark, space
  int stop_bits = 1;            // 1 or 2
  std::string flow_control = "none";  // none, xonxoff, rtscts, dtrdsr

  static SerialOptions from_config(const config::Node& node);
};
std::unique_ptr<ByteStream> make_serial_stream(SerialOptions options);

// ---- TCP client (ser2net, the simulator, the board emulator) ----
struct TcpOptions {
  std::string host = "127.0.0.1";  // numeric address or "localhost": no DNS lookup in the loop
  int port = 4001;

  static TcpOptions from_config(const config::Node& node);
};
std::unique_ptr<ByteStream> make_tcp_stream(TcpOptions options);

// The configured transport: `transport: tcp|serial` with a `tcp:` or `serial:` child.
std::unique_ptr<ByteStream> make_stream_from_config(const config::Node& node);

}  // namespace harvest::endeffector
