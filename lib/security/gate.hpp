// The receiver's door for commands (docs/security.md): a Verifier plus what a
// process does with a refusal. Every refusal is counted (a total and one
// counter per reason, for PROCESS_STATUS) and logged, at most one line a
// second per gate with how many refusals the line stands for, so a stray or
// hostile publisher cannot flood the log. A refused command is never handed on.
#pragma once

#include <spdlog/spdlog.h>

#include <functional>
#include <string>

#include "runtime/log_limiter.hpp"
#include "security/auth.hpp"

namespace harvest::security {

class CommandGate {
 public:
  // `what` names the commands in counters and log lines ("ROBOT_COMMAND");
  // `count` adds to a process counter (rt::Node::count).
  using CountFn = std::function<void(const std::string& counter, int64_t n)>;
  CommandGate(std::string what, Verifier verifier, const rt::Clock& clock, CountFn count);

  template <class Msg>
  bool admit(const Msg& msg) {
    const Verdict v = verifier_.check(msg);
    if (v == Verdict::ok) return true;
    refused(v, msg.auth.sender, msg.auth.seq);
    return false;
  }

  const Verifier& verifier() const { return verifier_; }
  // Counter names: "<prefix>_refused" and "<prefix>_<reason>", prefix = what
  // lower-cased ("robot_command_refused", "robot_command_replayed").
  std::string counter(Verdict v) const;
  std::string refused_counter() const { return prefix_ + "_refused"; }

 private:
  void refused(Verdict v, const std::string& sender, int64_t seq);

  std::string what_, prefix_;
  Verifier verifier_;
  const rt::Clock* clock_;
  CountFn count_;
  rt::LogLimiter log_;
};

}  // namespace harvest::security
