#include "can/socketcan.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace harvest::can {
namespace {

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

ErrorReport decode_error_frame(const CanFrame& frame) {
  ErrorReport r;
  const uint32_t cls = frame.id & CAN_ERR_MASK;
  std::string text;
  const auto add = [&text](const char* s) { text += text.empty() ? s : std::string(", ") + s; };
  if (cls & CAN_ERR_TX_TIMEOUT) add("tx timeout");
  if (cls & CAN_ERR_LOSTARB) add("lost arbitration");
  if (cls & CAN_ERR_CRTL) {
    const uint8_t c = frame.data[1];
    if (c & CAN_ERR_CRTL_RX_OVERFLOW) add("rx overflow");
    if (c & CAN_ERR_CRTL_TX_OVERFLOW) add("tx overflow");
    if (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) {
      add("error warning");
      r.state = BusState::kWarning;
    }
    if (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) {
      add("error passive");
      r.state = BusState::kPassive;
    }
    if (c & CAN_ERR_CRTL_ACTIVE) add("back to error active");
  }
  if (cls & CAN_ERR_PROT) add("protocol violation");
  if (cls & CAN_ERR_TRX) add("transceiver error");
  if (cls & CAN_ERR_ACK) add("no ack (no other node on the bus?)");
  if (cls & CAN_ERR_BUSERROR) add("bus error");
  if (cls & CAN_ERR_BUSOFF) {
    add("bus off");
    r.bus_off = true;
    r.state = BusState::kBusOff;
  }
  if (cls & CAN_ERR_RESTARTED) {
    add("controller restarted");
    r.restarted = true;
    r.state = BusState::kActive;
  }
  r.text = text.empty() ? "error frame" : text;
  return r;
}

SocketCanBus::SocketCanBus(const std::string& interface) : interface_(interface) {
  if (interface.empty() || interface.size() >= IFNAMSIZ)
    throw CanError("socketcan: invalid interface name '" + interface + "'");
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) {
    const int err = errno;
    if (err == EAFNOSUPPORT || err == EPROTONOSUPPORT)
      throw CanError("socketcan:" + interface + ": this kernel has no SocketCAN support (" + errno_text(err) +
                     "); load the can and can_raw modules, or use the udp_multicast virtual bus");
    throw CanError("socketcan:" + interface + ": cannot open a CAN socket: " + errno_text(err));
  }
  const unsigned index = ::if_nametoindex(interface.c_str());
  if (index == 0) {
    ::close(fd_);
    fd_ = -1;
    throw CanError("socketcan:" + interface + ": no such network interface (bring it up with: ip link set " +
                   interface + " up type can bitrate 1000000 restart-ms 100)");
  }
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask));
  const int on = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof(on));
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) < 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw CanError("socketcan:" + interface + ": bind failed: " + errno_text(err));
  }
}

SocketCanBus::~SocketCanBus() {
  if (fd_ >= 0) ::close(fd_);
}

void SocketCanBus::send(const CanFrame& frame) {
  if (frame.dlc > 8) throw CanError("socketcan: dlc > 8");
  can_frame raw{};
  raw.can_id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0u) | (frame.remote ? CAN_RTR_FLAG : 0u);
  raw.can_dlc = frame.dlc;
  std::memcpy(raw.data, frame.data.data(), 8);
  const ssize_t n = ::write(fd_, &raw, sizeof(raw));
  if (n != static_cast<ssize_t>(sizeof(raw))) {
    const int err = errno;
    if (err == ENOBUFS || err == EAGAIN)
      throw CanError("socketcan:" + interface_ + ": transmit queue full (bus off or no other node acknowledging?)");
    throw CanError("socketcan:" + interface_ + ": send failed: " + errno_text(err));
  }
}

std::optional<CanFrame> SocketCanBus::receive() {
  can_frame raw{};
  iovec iov{&raw, sizeof(raw)};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof(control);
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return std::nullopt;
    throw CanError("socketcan:" + interface_ + ": receive failed: " + errno_text(errno));
  }
  if (n != static_cast<ssize_t>(sizeof(raw))) return std::nullopt;  // CAN FD frame on a classic socket: ignore
  CanFrame f;
  f.extended = raw.can_id & CAN_EFF_FLAG;
  f.remote = raw.can_id & CAN_RTR_FLAG;
  f.error = raw.can_id & CAN_ERR_FLAG;
  f.id = raw.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  if (f.error) f.id = raw.can_id & CAN_ERR_MASK;
  f.dlc = raw.can_dlc > 8 ? 8 : raw.can_dlc;
  std::memcpy(f.data.data(), raw.data, 8);
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
      timeval tv;
      std::memcpy(&tv, CMSG_DATA(c), sizeof(tv));
      f.timestamp_us = static_cast<int64_t>(tv.tv_sec) * 1'000'000 + tv.tv_usec;
    }
  }
  if (f.error) {
    const ErrorReport r = decode_error_frame(f);
    if (r.bus_off || r.restarted || r.state != BusState::kActive) state_ = r.state;
  }
  return f;
}

void SocketCanBus::set_filters(const std::vector<CanFilter>& filters) {
  std::vector<can_filter> raw;
  for (const auto& f : filters) raw.push_back({f.id, f.mask});
  // An empty list means "everything": the kernel default filter.
  if (raw.empty()) raw.push_back({0, 0});
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, raw.data(),
                   static_cast<socklen_t>(raw.size() * sizeof(can_filter))) < 0)
    throw CanError("socketcan:" + interface_ + ": cannot set receive filters: " + errno_text(errno));
}

}  // namespace harvest::can
