#include "security/gate.hpp"

#include <cctype>

namespace harvest::security {
namespace {

std::string counter_word(const char* reason) {
  std::string out;
  for (const char* p = reason; *p; ++p) out += *p == ' ' ? '_' : static_cast<char>(std::tolower(*p));
  return out;
}

}  // namespace

CommandGate::CommandGate(std::string what, Verifier verifier, const rt::Clock& clock, CountFn count)
    : what_(std::move(what)), verifier_(std::move(verifier)), clock_(&clock), count_(std::move(count)) {
  prefix_ = counter_word(what_.c_str());
}

std::string CommandGate::counter(Verdict v) const { return prefix_ + "_" + counter_word(to_string(v)); }

void CommandGate::refused(Verdict v, const std::string& sender, int64_t seq) {
  count_(refused_counter(), 1);
  count_(counter(v), 1);
  int64_t unlogged = 0;
  rt::Micros since = 0;
  if (!log_.admit(clock_->now(), unlogged, since)) return;
  // The sender string is the attacker's text: quoted, and cut short.
  const std::string who = sender.size() > 64 ? sender.substr(0, 64) + "..." : sender;
  if (unlogged > 0) {
    spdlog::warn("{} refused ({}): sender '{}' seq {} (and {} more refused in the {:.1f} s before)", what_,
                 to_string(v), who, seq, unlogged, rt::to_seconds(since));
  } else {
    spdlog::warn("{} refused ({}): sender '{}' seq {}", what_, to_string(v), who, seq);
  }
}

}  // namespace harvest::security
