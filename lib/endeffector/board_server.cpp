#include "endeffector/board_server.hpp"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "endeffector/fd_io.hpp"

namespace harvest::endeffector {

namespace {
constexpr std::size_t kMaxPending = 64 * 1024;  // a client that does not read loses telemetry, not our memory
}

BoardServer::BoardServer(BoardEmulator& board, const std::string& host, int port) : board_(board) {
  const std::string what = "board server " + host + ":" + std::to_string(port);
  sockaddr_in addr = ipv4_address(host, port, what);
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw TransportError(what + ": socket: " + std::strerror(errno));
  const int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(listen_fd_, 4) != 0) {
    const std::string err = std::strerror(errno);
    ::close(listen_fd_);
    throw TransportError(what + ": " + err);
  }
  socklen_t len = sizeof addr;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
}

BoardServer::~BoardServer() {
  close_client();
  if (listen_fd_ >= 0) ::close(listen_fd_);
}

void BoardServer::close_client() {
  if (client_fd_ >= 0) ::close(client_fd_);
  client_fd_ = -1;
  pending_.clear();
}

void BoardServer::service(Micros now) {
  const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd >= 0) {
    close_client();
    client_fd_ = fd;
    ++connections_;
    board_.new_session(now);
  }
  if (client_fd_ < 0) return;
  uint8_t buf[512];
  while (true) {
    const IoResult r = fd_read(client_fd_, buf);
    if (r.status == IoResult::kOk) {
      board_.receive(std::span(buf, r.bytes), now);
      continue;
    }
    if (r.status != IoResult::kWouldBlock) {
      close_client();
      return;
    }
    break;
  }
  pending_ += board_.produce(now);
  flush();
}

void BoardServer::flush() {
  while (!pending_.empty() && client_fd_ >= 0) {
    const IoResult r =
        fd_write(client_fd_, std::span(reinterpret_cast<const uint8_t*>(pending_.data()), pending_.size()));
    if (r.status == IoResult::kOk) {
      pending_.erase(0, r.bytes);
    } else if (r.status == IoResult::kWouldBlock) {
      break;
    } else {
      close_client();
      return;
    }
  }
  if (pending_.size() > kMaxPending) {
    dropped_ += static_cast<int64_t>(pending_.size());
    pending_.clear();  // whole frames are lost; the host's parser resynchronises on the next '$'
  }
}

void BoardServer::close_mid_frame(Micros now) {
  if (client_fd_ < 0) return;
  pending_ += board_.produce(now);  // whole frames first, then half of one more
  const std::string frame = encode(Frame{0, IrSample{0}});
  pending_ += frame.substr(0, frame.size() / 2);
  flush();
  close_client();
}

}  // namespace harvest::endeffector
