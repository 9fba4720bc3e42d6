#include "endeffector/fd_io.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace harvest::endeffector {

IoResult fd_read(int fd, std::span<uint8_t> buffer) {
  const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), 0);
  if (n > 0) return {IoResult::kOk, static_cast<std::size_t>(n), {}};
  if (n == 0) return {IoResult::kClosed, 0, {}};
  if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return {IoResult::kWouldBlock, 0, {}};
  if (errno == ECONNRESET) return {IoResult::kClosed, 0, std::strerror(errno)};
  return {IoResult::kError, 0, std::strerror(errno)};
}

IoResult fd_write(int fd, std::span<const uint8_t> bytes) {
  // MSG_NOSIGNAL: a peer that went away must give EPIPE, not kill the process.
  const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  if (n >= 0) return {IoResult::kOk, static_cast<std::size_t>(n), {}};
  if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return {IoResult::kWouldBlock, 0, {}};
  if (errno == EPIPE || errno == ECONNRESET) return {IoResult::kClosed, 0, std::strerror(errno)};
  return {IoResult::kError, 0, std::strerror(errno)};
}

void set_nonblocking(int fd) {
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

sockaddr_in ipv4_address(const std::string& host, int port, const std::string& what) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  const std::string numeric = host == "localhost" ? "127.0.0.1" : host;
  if (::inet_pton(AF_INET, numeric.c_str(), &addr.sin_addr) != 1) {
    throw TransportError(what + ": host '" + host + "' is not an IPv4 address (names are not resolved)");
  }
  return addr;
}

}  // namespace harvest::endeffector
