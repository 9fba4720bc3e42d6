// The console's buttons as operator commands, and each command's fate as the
// controller's reply on HARVEST_STATUS tells it (servo::acknowledgement, the
// same matching harvest-operator uses): waiting, accepted, refused, or no
// reply within a timeout. The page shows the last command's line.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "harvest/harvest_status_t.hpp"
#include "servo/operator_command.hpp"

namespace harvest::console {

// A request from the page, {"command": "start"}: the verb, or
// std::invalid_argument saying what is wrong (not JSON, no command, unknown verb).
std::string verb_of_request(const std::string& text);

class CommandTracker {
 public:
  // `source` names this console in the command (unique: it carries the pid);
  // a command unanswered for `timeout_us` is reported as "no reply".
  CommandTracker(std::string source, int64_t timeout_us = 3'000'000);

  const std::string& source() const { return source_; }

  // The message for `verb`, stamped `now_us`; it becomes the tracked command.
  servo::OperatorMessage command(const std::string& verb, int64_t now_us);
  // A request the console refused (verb_of_request's reason): it becomes the
  // shown line, state "invalid", so the page keeps showing why nothing was sent.
  void invalid_request(const std::string& why, int64_t now_us);
  // The send failed (LCM publish): shown as such, nothing is awaited.
  void send_failed(int64_t now_us);
  void on_status(const harvest_status_t& m, int64_t now_us);

  // {"verb", "state": waiting|accepted|refused|no reply|send failed|invalid, "detail", "age_s"}; null before the first.
  nlohmann::json to_json(int64_t now_us) const;

 private:
  std::string source_;
  int64_t timeout_us_;
  struct Pending {
    std::string verb;
    int64_t sent_us = 0;
    std::string state = "waiting";
    std::string detail;
  };
  std::optional<Pending> last_;
};

}  // namespace harvest::console
