#include "security/auth.hpp"

#include <sodium.h>

#include <algorithm>
#include <stdexcept>

namespace harvest::security {

const char* to_string(Verdict v) {
  switch (v) {
    case Verdict::ok:
      return "ok";
    case Verdict::unsigned_command:
      return "unsigned";
    case Verdict::unknown_sender:
      return "unknown sender";
    case Verdict::bad_mac:
      return "bad MAC";
    case Verdict::stale:
      return "stale";
    case Verdict::future:
      return "from the future";
    case Verdict::replayed:
      return "replayed";
  }
  return "?";
}

Mac compute_mac(const Key& key, const uint8_t* data, std::size_t size) {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
  Mac mac{};
  crypto_auth(mac.data(), data, size, key.bytes.data());
  return mac;
}

Signer::Signer(Key key, std::string sender, const rt::Clock& clock)
    : key_(key), sender_(std::move(sender)), clock_(&clock) {
  if (sender_.empty()) throw std::invalid_argument("a command signer needs a sender id");
}

int64_t Signer::next_seq() {
  last_seq_ = std::max(last_seq_ + 1, clock_->now());
  return last_seq_;
}

Verifier::Verifier(Key key, Policy policy, const rt::Clock& clock)
    : key_(key), policy_(std::move(policy)), clock_(&clock) {
  if (policy_.max_age_us <= 0 || policy_.max_ahead_us < 0) {
    throw std::invalid_argument("command authority: max_age must be > 0 and max_ahead >= 0");
  }
}

bool Verifier::is_unsigned(const std::string& sender, const Mac& mac) {
  return sender.empty() || std::all_of(mac.begin(), mac.end(), [](uint8_t b) { return b == 0; });
}

int64_t Verifier::refused() const {
  int64_t n = 0;
  for (int i = 1; i < kVerdictCount; ++i) n += counts_[i];
  return n;
}

Verdict Verifier::check_bytes(const uint8_t* bytes, std::size_t size, const std::string& sender, int64_t seq,
                              int64_t utime, const Mac& mac) {
  if (is_unsigned(sender, mac)) return count(Verdict::unsigned_command);
  if (std::find(policy_.senders.begin(), policy_.senders.end(), sender) == policy_.senders.end()) {
    return count(Verdict::unknown_sender);
  }
  if (crypto_auth_verify(mac.data(), bytes, size, key_.bytes.data()) != 0) return count(Verdict::bad_mac);
  const rt::Micros now = clock_->now();
  if (utime < now - policy_.max_age_us) return count(Verdict::stale);
  if (utime > now + policy_.max_ahead_us) return count(Verdict::future);
  auto it = last_seq_.find(sender);
  if (it != last_seq_.end() && seq <= it->second) return count(Verdict::replayed);
  last_seq_[sender] = seq;
  return count(Verdict::ok);
}

}  // namespace harvest::security
