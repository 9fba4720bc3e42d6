// TCP client transport: asynchronous connect, completed by poll_open().
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "endeffector/fd_io.hpp"
#include "endeffector/transport.hpp"

namespace harvest::endeffector {

TcpOptions TcpOptions::from_config(const config::Node& node) {
  TcpOptions o;
  o.host = node.get(transport_keys::host);
  o.port = node.get(transport_keys::tcp_port);
  ipv4_address(o.host, o.port, node.key_path("host"));  // validate now, not at the first connect
  return o;
}

namespace {

class TcpStream final : public ByteStream {
 public:
  explicit TcpStream(TcpOptions o) : o_(std::move(o)) {}
  ~TcpStream() override { close(); }

  std::string describe() const override { return "tcp:" + o_.host + ":" + std::to_string(o_.port); }

  void open() override {
    close();
    const sockaddr_in addr = ipv4_address(o_.host, o_.port, describe());
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw TransportError(describe() + ": socket: " + std::strerror(errno));
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);  // small frames, latency matters
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) {
      state_ = LinkState::kOpen;
    } else if (errno == EINPROGRESS) {
      state_ = LinkState::kConnecting;
    } else {
      fail("connect");
    }
  }

  LinkState poll_open() override {
    if (state_ != LinkState::kConnecting) return state_;
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, 0) <= 0) return state_;
    int err = 0;
    socklen_t len = sizeof err;
    ::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &err, &len);
    if (err != 0) {
      errno = err;
      fail("connect");
    }
    state_ = LinkState::kOpen;
    return state_;
  }

  LinkState state() const override { return state_; }
  int fd() const override { return fd_; }
  IoResult read(std::span<uint8_t> b) override { return fd_read(fd_, b); }
  IoResult write(std::span<const uint8_t> b) override { return fd_write(fd_, b); }

  void close() override {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    state_ = LinkState::kClosed;
  }

 private:
  [[noreturn]] void fail(const char* what) {
    const std::string msg = describe() + ": " + what + ": " + std::strerror(errno);
    close();
    throw TransportError(msg);
  }

  TcpOptions o_;
  int fd_ = -1;
  LinkState state_ = LinkState::kClosed;
};

}  // namespace

std::unique_ptr<ByteStream> make_tcp_stream(TcpOptions options) { return std::make_unique<TcpStream>(std::move(options)); }

std::unique_ptr<ByteStream> make_stream_from_config(const config::Node& node) {
  const std::string kind = node.get(transport_keys::transport);
  // A file may carry both sections and switch with `transport` alone (e.g.
  // --set link.transport=serial); the section not in use is still validated.
  if (kind == "serial") {
    if (node.has("tcp")) TcpOptions::from_config(node.child("tcp"));
    auto o = SerialOptions::from_config(node.required_child("serial"));
    return make_serial_stream(std::move(o));
  }
  if (node.has("serial")) SerialOptions::from_config(node.child("serial"));
  return make_tcp_stream(TcpOptions::from_config(node.child("tcp")));
}

}  // namespace harvest::endeffector
