// A signed command for the security tests: a real twist_t body, then the
// auth fields laid out as lcm-gen lays out auth_t as a command's last field.
#pragma once

#include <cstdint>
#include <cstring>
#include <harvest/twist_t.hpp>
#include <string>

namespace harvest::test {

struct TwistCommand {
  harvest::twist_t twist{};
  struct {
    std::string sender;
    int64_t seq = 0;
    int64_t utime = 0;
    int8_t mac[32] = {};
  } auth;

  int getEncodedSize() const {
    return static_cast<int>(twist.getEncodedSize() + 4 + auth.sender.size() + 1 + 16 + sizeof(auth.mac));
  }
  int encode(void* buf, int offset, int maxlen) const {
    auto* p = static_cast<uint8_t*>(buf) + offset;
    int n = twist.encode(p, 0, maxlen);
    uint32_t len = static_cast<uint32_t>(auth.sender.size() + 1);
    std::memcpy(p + n, &len, 4);
    n += 4;
    std::memcpy(p + n, auth.sender.c_str(), len);
    n += static_cast<int>(len);
    std::memcpy(p + n, &auth.seq, 8);
    std::memcpy(p + n + 8, &auth.utime, 8);
    n += 16;
    std::memcpy(p + n, auth.mac, sizeof(auth.mac));
    return n + static_cast<int>(sizeof(auth.mac));
  }
};

}  // namespace harvest::test
