// Serial-line transport through libserialport (the field link).
#include <libserialport.h>
#include <poll.h>

#include <filesystem>

#include "endeffector/transport.hpp"

namespace harvest::endeffector {

SerialOptions SerialOptions::from_config(const config::Node& node) {
  namespace k = transport_keys;
  SerialOptions o;
  o.port = node.get(k::serial_port);
  if (o.port.empty()) node.fail("port", "a serial device path such as /dev/ttyUSB0");
  o.baud = node.get(k::baud);
  o.data_bits = node.get(k::data_bits);
  o.parity = node.get(k::parity);
  o.stop_bits = node.get(k::stop_bits);
  o.flow_control = node.get(k::flow_control);
  return o;
}

namespace {

sp_parity parity_of(const std::string& p) {
  if (p == "odd") return SP_PARITY_ODD;
  if (p == "even") return SP_PARITY_EVEN;
  if (p == "mark") return SP_PARITY_MARK;
  if (p == "space") return SP_PARITY_SPACE;
  return SP_PARITY_NONE;
}

sp_flowcontrol flow_of(const std::string& f) {
  if (f == "xonxoff") return SP_FLOWCONTROL_XONXOFF;
  if (f == "rtscts") return SP_FLOWCONTROL_RTSCTS;
  if (f == "dtrdsr") return SP_FLOWCONTROL_DTRDSR;
  return SP_FLOWCONTROL_NONE;
}

std::string last_error() {
  // Only meaningful after SP_ERR_FAIL (an OS error).
  char* msg = sp_last_error_message();
  std::string out = msg ? msg : "unknown error";
  sp_free_error_message(msg);
  return out;
}

std::string error_text(sp_return r) {
  switch (r) {
    case SP_ERR_FAIL:
      return last_error();
    case SP_ERR_ARG:
      return "invalid argument (does the device exist?)";
    case SP_ERR_MEM:
      return "out of memory";
    case SP_ERR_SUPP:
      return "not supported by this device";
    default:
      return "error " + std::to_string(static_cast<int>(r));
  }
}

class SerialStream final : public ByteStream {
 public:
  explicit SerialStream(SerialOptions o) : o_(std::move(o)) {}
  ~SerialStream() override { close(); }

  std::string describe() const override { return "serial:" + o_.port; }

  void open() override {
    close();
    std::error_code ec;
    if (!std::filesystem::exists(o_.port, ec))  // libserialport only says "invalid argument"
      throw TransportError("serial port '" + o_.port + "': no such device (is the adapter plugged in?)");
    check(sp_get_port_by_name(o_.port.c_str(), &port_), "no such serial port");
    check(sp_open(port_, SP_MODE_READ_WRITE), "cannot open");
    opened_ = true;
    check(sp_set_baudrate(port_, o_.baud), "cannot set baud rate " + std::to_string(o_.baud));
    check(sp_set_bits(port_, o_.data_bits), "cannot set data bits");
    check(sp_set_parity(port_, parity_of(o_.parity)), "cannot set parity " + o_.parity);
    check(sp_set_stopbits(port_, o_.stop_bits), "cannot set stop bits");
    check(sp_set_flowcontrol(port_, flow_of(o_.flow_control)), "cannot set flow control " + o_.flow_control);
    check(sp_get_port_handle(port_, &fd_), "no file descriptor");
    sp_flush(port_, SP_BUF_BOTH);  // stale bytes from before we opened are not ours
  }

  LinkState poll_open() override { return state(); }
  LinkState state() const override { return fd_ >= 0 ? LinkState::kOpen : LinkState::kClosed; }
  int fd() const override { return fd_; }

  IoResult read(std::span<uint8_t> buffer) override {
    const sp_return n = sp_nonblocking_read(port_, buffer.data(), buffer.size());
    if (n < 0) return {IoResult::kError, 0, error_text(n)};
    if (n > 0) return {IoResult::kOk, static_cast<std::size_t>(n), {}};
    // Nothing to read although poll said readable: a hang-up (USB adapter unplugged).
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL))) return {IoResult::kClosed, 0, "hang-up"};
    return {IoResult::kWouldBlock, 0, {}};
  }

  IoResult write(std::span<const uint8_t> bytes) override {
    const sp_return n = sp_nonblocking_write(port_, bytes.data(), bytes.size());
    if (n < 0) return {IoResult::kError, 0, error_text(n)};
    return {n == 0 ? IoResult::kWouldBlock : IoResult::kOk, static_cast<std::size_t>(n), {}};
  }

  void close() override {
    if (port_) {
      if (opened_) sp_close(port_);
      sp_free_port(port_);
    }
    port_ = nullptr;
    opened_ = false;
    fd_ = -1;
  }

 private:
  void check(sp_return r, const std::string& what) {
    if (r >= 0) return;
    const std::string msg = "serial port '" + o_.port + "': " + what + ": " + error_text(r);
    close();
    throw TransportError(msg);
  }

  SerialOptions o_;
  sp_port* port_ = nullptr;
  bool opened_ = false;
  int fd_ = -1;
};

}  // namespace

std::unique_ptr<ByteStream> make_serial_stream(SerialOptions options) {
  return std::make_unique<SerialStream>(std::move(options));
}

}  // namespace harvest::endeffector
