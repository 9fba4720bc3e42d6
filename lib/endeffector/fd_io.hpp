// Non-blocking read/write on a socket descriptor, mapped to IoResult.
#pragma once

#include <netinet/in.h>

#include <span>
#include <string>

#include "endeffector/transport.hpp"

namespace harvest::endeffector {

IoResult fd_read(int fd, std::span<uint8_t> buffer);
IoResult fd_write(int fd, std::span<const uint8_t> bytes);
void set_nonblocking(int fd);
// Parse "127.0.0.1" or "localhost" into a sockaddr_in; throws TransportError naming `what`.
sockaddr_in ipv4_address(const std::string& host, int port, const std::string& what);

}  // namespace harvest::endeffector
