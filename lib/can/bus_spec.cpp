#include "can/bus_spec.hpp"

#include <arpa/inet.h>
#include <net/if.h>

#include "can/can_bus.hpp"

namespace harvest::can {
namespace {

[[noreturn]] void bad(const std::string& spec, const std::string& why) {
  throw CanError("CAN bus '" + spec + "': " + why +
                 " (expected socketcan:<interface> or udp_multicast[:<group>[:<port>]][?ttl=<0..255>])");
}

int parse_int(const std::string& spec, const std::string& what, const std::string& text, int lo, int hi) {
  std::size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v < lo || v > hi)
    bad(spec, "bad " + what + " '" + text + "', expected " + std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

}  // namespace

std::string BusSpec::describe() const {
  if (kind == Kind::kSocketCan) return "socketcan:" + interface;
  return "udp_multicast:" + udp.group + ":" + std::to_string(udp.port) + "?ttl=" + std::to_string(udp.hop_limit);
}

BusSpec parse_bus_spec(const std::string& spec) {
  const auto question = spec.find('?');
  const std::string base = spec.substr(0, question);
  const std::string query = question == std::string::npos ? "" : spec.substr(question + 1);
  const auto colon = base.find(':');
  const std::string kind = base.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : base.substr(colon + 1);
  BusSpec s;
  if (kind == "socketcan") {
    s.kind = BusSpec::Kind::kSocketCan;
    if (rest.empty()) bad(spec, "no interface");
    if (rest.size() >= IFNAMSIZ) bad(spec, "interface name longer than " + std::to_string(IFNAMSIZ - 1));
    if (!query.empty()) bad(spec, "socketcan takes no options");
    s.interface = rest;
    return s;
  }
  if (kind != "udp_multicast") bad(spec, "unknown transport '" + kind + "'");
  s.kind = BusSpec::Kind::kUdpMulticast;
  if (!rest.empty()) {
    const auto c2 = rest.find(':');
    s.udp.group = rest.substr(0, c2);
    if (c2 != std::string::npos) s.udp.port = parse_int(spec, "port", rest.substr(c2 + 1), 1, 65535);
  }
  in_addr group{};
  if (::inet_pton(AF_INET, s.udp.group.c_str(), &group) != 1 || !IN_MULTICAST(ntohl(group.s_addr)))
    bad(spec, "'" + s.udp.group + "' is not an IPv4 multicast address");
  std::size_t begin = 0;
  while (begin < query.size()) {
    const auto end = std::min(query.find('&', begin), query.size());
    const std::string item = query.substr(begin, end - begin);
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    if (key == "ttl" && eq != std::string::npos)
      s.udp.hop_limit = parse_int(spec, "ttl", item.substr(eq + 1), 0, 255);
    else
      bad(spec, "unknown option '" + item + "'");
    begin = end + 1;
  }
  return s;
}

}  // namespace harvest::can
