// Command authority (docs/security.md): a sender signs each command with a
// keyed MAC (libsodium crypto_auth, HMAC-SHA-512-256) over the message's LCM
// encoding with the MAC bytes zeroed, so the type fingerprint, every field and
// the auth fields (sender, seq, utime) are covered. A receiver obeys a command
// only if the MAC is right, the sender is one it was configured to obey, the
// seq is above the last one it accepted from that sender, and utime lies in
// the validity window on its own (injected) clock.
//
// Messages are any LCM type with an `auth` member shaped like auth_t:
// string sender; int64_t seq; int64_t utime; int8_t mac[32].
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "runtime/clock.hpp"
#include "security/key.hpp"

namespace harvest::security {

using Mac = std::array<uint8_t, kMacBytes>;

Mac compute_mac(const Key& key, const uint8_t* data, std::size_t size);

// Why a command was refused (or ok). Order = the order of the checks.
enum class Verdict {
  ok,
  unsigned_command,  // no sender or an all-zero MAC: sent by something that does not sign
  unknown_sender,    // signed, but not by a sender this receiver obeys
  bad_mac,           // wrong key, or the message was altered after signing
  stale,             // signed longer ago than the validity window (or a replay of an old one)
  future,            // signed further ahead of the receiver's clock than the allowed skew
  replayed,          // seq not above the last accepted one from this sender
};
constexpr int kVerdictCount = 7;
const char* to_string(Verdict v);

struct Policy {
  std::vector<std::string> senders;            // whom to obey; empty obeys nobody
  rt::Micros max_age_us = 1 * rt::kSecond;     // oldest signing time accepted
  rt::Micros max_ahead_us = 100 * rt::kMilli;  // sender clock ahead of ours
};

// Encodes msg with its MAC zeroed: the bytes the MAC covers.
template <class Msg>
std::vector<uint8_t> signed_bytes(Msg msg) {
  std::memset(msg.auth.mac, 0, sizeof(msg.auth.mac));
  std::vector<uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

class Signer {
 public:
  // seq starts at the clock's microseconds, so a restarted sender continues
  // above everything it sent before without keeping state on disk, and a
  // replay (log clock) signs exactly as the recording did.
  Signer(Key key, std::string sender, const rt::Clock& clock);

  template <class Msg>
  void sign(Msg& msg) {
    msg.auth.sender = sender_;
    msg.auth.seq = next_seq();
    msg.auth.utime = clock_->now();
    auto bytes = signed_bytes(msg);
    Mac mac = compute_mac(key_, bytes.data(), bytes.size());
    static_assert(sizeof(msg.auth.mac) == kMacBytes, "auth mac must be 32 bytes");
    std::memcpy(msg.auth.mac, mac.data(), kMacBytes);
  }

  const std::string& sender() const { return sender_; }
  int64_t next_seq();

 private:
  Key key_;
  std::string sender_;
  const rt::Clock* clock_;
  int64_t last_seq_ = 0;
};

class Verifier {
 public:
  Verifier(Key key, Policy policy, const rt::Clock& clock);

  template <class Msg>
  Verdict check(const Msg& msg) {
    Mac mac{};
    static_assert(sizeof(msg.auth.mac) == kMacBytes, "auth mac must be 32 bytes");
    std::memcpy(mac.data(), msg.auth.mac, kMacBytes);
    auto bytes = signed_bytes(msg);
    return check_bytes(bytes.data(), bytes.size(), msg.auth.sender, msg.auth.seq, msg.auth.utime, mac);
  }

  // bytes: the message encoded with its MAC zeroed. The seq is remembered
  // only when every check passed, so a refused command never moves it.
  Verdict check_bytes(const uint8_t* bytes, std::size_t size, const std::string& sender, int64_t seq, int64_t utime,
                      const Mac& mac);

  // Refusals so far per verdict (index = Verdict), for PROCESS_STATUS.
  const std::array<int64_t, kVerdictCount>& counts() const { return counts_; }
  int64_t refused() const;
  const Policy& policy() const { return policy_; }
  const Key& key() const { return key_; }

 private:
  static bool is_unsigned(const std::string& sender, const Mac& mac);
  Verdict count(Verdict v) {
    ++counts_[static_cast<int>(v)];
    return v;
  }

  Key key_;
  Policy policy_;
  const rt::Clock* clock_;
  std::map<std::string, int64_t> last_seq_;
  std::array<int64_t, kVerdictCount> counts_{};
};

}  // namespace harvest::security
