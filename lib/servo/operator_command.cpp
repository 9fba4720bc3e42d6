#include "servo/operator_command.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <stdexcept>
#include <thread>

#include "runtime/channels.hpp"

namespace harvest::servo {

namespace {
const std::map<std::string, int8_t>& commands() {
  // int8_t{...} reads the constants' values: lcm-gen declares them `static const`
  // without a definition, so binding them to a reference (pair's constructor)
  // does not link in an unoptimised (sanitizer) build.
  using C = operator_command_t;
  static const std::map<std::string, int8_t> m{
      {"start", int8_t{C::START}},   {"pause", int8_t{C::PAUSE}},
      {"resume", int8_t{C::RESUME}}, {"abort", int8_t{C::ABORT}},
      {"home", int8_t{C::HOME}},     {"reset-fault", int8_t{C::RESET_FAULT}}};
  return m;
}
}  // namespace

const std::vector<std::string>& operator_verbs() {
  static const std::vector<std::string> v{"start", "pause",       "resume", "abort",
                                          "home",  "reset-fault", "estop",  "estop-clear"};
  return v;
}

OperatorMessage make_operator_message(const std::string& verb, const std::string& source, const std::string& reason,
                                      rt::Micros utime) {
  if (verb == "estop" || verb == "estop-clear") {
    emergency_stop_t e{};
    e.header.utime = utime;
    e.header.source_seq = -1;
    e.header.frame_id = "operator";
    e.engaged = verb == "estop";
    e.clear = verb == "estop-clear";
    e.source = source;
    e.reason = reason;
    return e;
  }
  const auto it = commands().find(verb);
  if (it == commands().end()) {
    std::string valid;
    for (const auto& v : operator_verbs()) valid += (valid.empty() ? "" : ", ") + v;
    throw std::invalid_argument("unknown operator command '" + verb + "' (expected one of: " + valid + ")");
  }
  operator_command_t c{};
  c.header.utime = utime;
  c.header.source_seq = -1;
  c.header.frame_id = "operator";
  c.command = it->second;
  c.source = source;
  return c;
}

std::string operator_source(const std::string& tool) {
  const char* user = std::getenv("USER");
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  return std::string(user ? user : "unknown") + "@" + host + " (" + tool + " " + std::to_string(getpid()) + ")";
}

int default_repeat(const std::string& verb) { return verb.rfind("estop", 0) == 0 ? 3 : 1; }

void sign_operator_message(OperatorMessage& msg, security::Signer& signer) {
  std::visit([&](auto& m) { signer.sign(m); }, msg);
}

bool send_operator_message(lcm::LCM& lcm, const std::string& prefix, OperatorMessage msg, int repeat,
                           security::Signer& signer) {
  for (int i = 0; i < repeat; ++i) {
    sign_operator_message(msg, signer);
    int rc = 0;
    if (const auto* e = std::get_if<emergency_stop_t>(&msg))
      rc = lcm.publish(prefix + channels::kEmergencyStop, e);
    else
      rc = lcm.publish(prefix + channels::kOperatorCommand, &std::get<operator_command_t>(msg));
    if (rc != 0) return false;
    if (i + 1 < repeat) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

Acknowledgement acknowledgement(const std::string& verb, const std::string& source, const harvest_status_t& status) {
  const auto has = [&](const std::string& text) { return status.summary.find(text) != std::string::npos; };
  if (verb == "estop") return {status.estop ? AckState::kAccepted : AckState::kWaiting, status.summary};
  if (verb == "estop-clear") return {status.estop ? AckState::kWaiting : AckState::kAccepted, status.summary};
  if (has("(from " + source + ")") && has("command refused")) return {AckState::kRefused, status.summary};
  static const std::map<std::string, std::string> accepted{
      {"start", "started by "}, {"pause", "paused by "}, {"resume", "resumed by "},
      {"abort", "aborted by "}, {"home", "homing ("},    {"reset-fault", "fault reset by "}};
  const auto it = accepted.find(verb);
  if (it != accepted.end() && has(it->second + source)) return {AckState::kAccepted, status.summary};
  return {AckState::kWaiting, status.summary};
}

}  // namespace harvest::servo
