#include "sim/ports.hpp"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace harvest::sim {

namespace {
// Binds a fresh socket to `port` (0: the kernel's choice); returns the port
// bound, or -1 with errno set.
int try_bind(int port, bool udp) {
  const int fd = ::socket(AF_INET, (udp ? SOCK_DGRAM : SOCK_STREAM) | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(static_cast<uint16_t>(port));
  socklen_t len = sizeof addr;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0;
  const int err = errno;
  ::close(fd);
  errno = err;
  return ok ? ntohs(addr.sin_port) : -1;
}
}  // namespace

int free_port(bool udp) {
  const int port = try_bind(0, udp);
  if (port < 0) throw std::runtime_error(std::string("no free port: ") + std::strerror(errno));
  return port;
}

bool port_free(int port, bool udp) { return try_bind(port, udp) == port; }

}  // namespace harvest::sim
