#include "can/udp_multicast.hpp"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "can/python_can_codec.hpp"

namespace harvest::can {
namespace {

[[noreturn]] void fail(const UdpMulticastOptions& o, const std::string& what) {
  throw CanError("udp_multicast:" + o.group + ":" + std::to_string(o.port) + ": " + what + ": " + std::strerror(errno));
}

}  // namespace

UdpMulticastBus::UdpMulticastBus(UdpMulticastOptions options) : options_(std::move(options)) {
  in_addr group{};
  if (::inet_pton(AF_INET, options_.group.c_str(), &group) != 1 || !IN_MULTICAST(ntohl(group.s_addr)))
    throw CanError("udp_multicast: '" + options_.group + "' is not an IPv4 multicast address");
  if (options_.port <= 0 || options_.port > 65535)
    throw CanError("udp_multicast: port " + std::to_string(options_.port) + " out of range");
  if (options_.hop_limit < 0 || options_.hop_limit > 255)
    throw CanError("udp_multicast: ttl " + std::to_string(options_.hop_limit) + " out of range 0..255");

  rx_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  tx_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (rx_fd_ < 0 || tx_fd_ < 0) {
    if (rx_fd_ >= 0) ::close(rx_fd_);
    if (tx_fd_ >= 0) ::close(tx_fd_);
    fail(options_, "socket");
  }
  try {
    const int on = 1;
    if (::setsockopt(rx_fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on)) < 0) fail(options_, "SO_REUSEADDR");
    sockaddr_in bind_addr{};
    bind_addr.sin_family = AF_INET;
    bind_addr.sin_port = htons(static_cast<uint16_t>(options_.port));
    bind_addr.sin_addr.s_addr = htonl(INADDR_ANY);
    if (::bind(rx_fd_, reinterpret_cast<sockaddr*>(&bind_addr), sizeof(bind_addr)) < 0) fail(options_, "bind");
    ip_mreq mreq{};
    mreq.imr_multiaddr = group;
    mreq.imr_interface.s_addr = htonl(INADDR_ANY);
    if (::setsockopt(rx_fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof(mreq)) < 0)
      fail(options_, "joining the multicast group (is there a multicast route? see docs/can.md)");
    ::setsockopt(rx_fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof(on));

    const unsigned char ttl = static_cast<unsigned char>(options_.hop_limit);
    if (::setsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof(ttl)) < 0) fail(options_, "IP_MULTICAST_TTL");
    const unsigned char loop = 1;  // other members on this host must see our frames
    ::setsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof(loop));
    sockaddr_in dest{};
    dest.sin_family = AF_INET;
    dest.sin_port = htons(static_cast<uint16_t>(options_.port));
    dest.sin_addr = group;
    if (::connect(tx_fd_, reinterpret_cast<sockaddr*>(&dest), sizeof(dest)) < 0) fail(options_, "connect");
    socklen_t len = sizeof(tx_addr_);
    if (::getsockname(tx_fd_, reinterpret_cast<sockaddr*>(&tx_addr_), &len) < 0) fail(options_, "getsockname");
  } catch (...) {
    ::close(rx_fd_);
    ::close(tx_fd_);
    throw;
  }
}

UdpMulticastBus::~UdpMulticastBus() {
  ::close(rx_fd_);
  ::close(tx_fd_);
}

std::string UdpMulticastBus::describe() const {
  BusSpec spec;
  spec.udp = options_;
  return spec.describe();
}

int UdpMulticastBus::multicast_ttl() const {
  unsigned char ttl = 0;
  socklen_t len = sizeof(ttl);
  if (::getsockopt(tx_fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, &len) < 0) fail(options_, "reading IP_MULTICAST_TTL");
  return ttl;
}

void UdpMulticastBus::send(const CanFrame& frame) {
  if (frame.dlc > 8) throw CanError("udp_multicast: dlc > 8");
  timeval tv{};
  ::gettimeofday(&tv, nullptr);  // transport timestamp only, as python-can's sender does
  const auto bytes = encode_python_can(frame, static_cast<double>(tv.tv_sec) + tv.tv_usec * 1e-6);
  if (::send(tx_fd_, bytes.data(), bytes.size(), 0) != static_cast<ssize_t>(bytes.size()))
    throw CanError(describe() + ": send failed: " + std::strerror(errno));
}

std::optional<CanFrame> UdpMulticastBus::receive() {
  for (;;) {
    uint8_t buf[4096];
    sockaddr_in from{};
    iovec iov{buf, sizeof(buf)};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval))];
    msghdr msg{};
    msg.msg_name = &from;
    msg.msg_namelen = sizeof(from);
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof(control);
    const ssize_t n = ::recvmsg(rx_fd_, &msg, MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return std::nullopt;
      throw CanError(describe() + ": receive failed: " + std::strerror(errno));
    }
    if (from.sin_port == tx_addr_.sin_port && from.sin_addr.s_addr == tx_addr_.sin_addr.s_addr) continue;  // our own
    CanFrame f;
    try {
      f = decode_python_can(buf, static_cast<std::size_t>(n));
    } catch (const CanError& e) {
      ++malformed_;
      last_error_ = e.what();
      continue;
    }
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
        timeval tv;
        std::memcpy(&tv, CMSG_DATA(c), sizeof(tv));
        f.timestamp_us = static_cast<int64_t>(tv.tv_sec) * 1'000'000 + tv.tv_usec;
      }
    }
    if (f.error || filters_.empty()) return f;
    for (const auto& filter : filters_)
      if (filter.matches(f)) return f;
  }
}

}  // namespace harvest::can
