// One process's command authority (docs/security.md): its `authority:` config
// section, and the object that signs what the process sends and checks what
// it obeys.
//   authority:
//     key: sim                           # or a key file (relative paths: to the config file)
//     sender: servo-controller           # this process's id on what it signs
//     controller: servo-controller       # the one sender obeyed for motion (robot link, ee-bridge)
//     operators: operator, console       # senders obeyed for operator commands, e-stop clear, RESET_FAULT
//     max_age_ms: 1000                   # oldest signing time accepted
//     max_ahead_ms: 100                  # sender clock ahead of the receiver
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"
#include "security/auth.hpp"
#include "security/gate.hpp"

namespace harvest::security {

// The key value naming the simulator's well-known key (sim_key()).
inline constexpr const char* kSimKeyName = "sim";

// The keys of a process's `authority` mapping (docs/security.md).
namespace authority_keys {
using config::Key;
inline constexpr Key<std::string> key{.name = "key",
                                      .doc = "`sim` (the simulator's public key) or a key file (harvest-keygen)",
                                      .required = true};
inline constexpr Key<std::string> sender{"sender", "", {}, "",
                                         "this process's sender id, which it signs commands with"};
inline constexpr Key<std::string> controller{"controller", "", {}, "",
                                             "the sender id of the one controller obeyed for motion commands"};
inline constexpr Key<std::string> operators{"operators", "operator, console", {}, "",
                                            "sender ids obeyed for fault resets and e-stop clears, comma-separated"};
inline constexpr Key<int> max_age_ms{"max_age_ms", 1000, {1, 60'000}, "ms", "a command signed longer ago is stale"};
inline constexpr Key<int> max_ahead_ms{"max_ahead_ms", 100, {0, 10'000}, "ms",
                                       "a sender's clock this far ahead is tolerated"};
}  // namespace authority_keys

struct AuthorityConfig {
  std::string key;  // kSimKeyName, or a key file path (absolute once loaded)
  std::string sender;
  std::string controller;
  std::vector<std::string> operators{"operator", "console"};  // authority_keys::operators, split
  rt::Micros max_age_us = authority_keys::max_age_ms.fallback * rt::kMilli;
  rt::Micros max_ahead_us = authority_keys::max_ahead_ms.fallback * rt::kMilli;

  // What a process needs from the section beyond the key; a missing part is
  // a config::Error naming the key.
  enum Needs : unsigned { kNothingElse = 0, kSender = 1, kController = 2 };
  static AuthorityConfig from_config(const config::Node& authority, unsigned needs = kNothingElse);
  // Its keys for the reference, as `path` in `where` (what `needs` makes required).
  static config::Section schema(const std::string& path, const std::string& where, unsigned needs = kNothingElse);

  Policy controller_policy() const { return Policy{{controller}, max_age_us, max_ahead_us}; }
  Policy operator_policy() const { return Policy{operators, max_age_us, max_ahead_us}; }

  // The key for a process on `bus` (a CAN bus string, or empty): the sim key
  // or the key file, loaded; a sim key on a real bus (socketcan) is refused.
  Key load(const std::string& bus = "") const;
};

// A key named the way configs and tools name it: kSimKeyName for the sim key,
// else a key file path (load_key's checks and errors).
Key load_named_key(const std::string& name);
// The key operator tools sign with unless told: $HARVEST_COMMAND_KEY, else "sim".
std::string default_command_key();

// A sim key on a socketcan bus throws; `what` names where the key came from.
void refuse_sim_key_on_real_bus(const Key& key, const std::string& bus, const std::string& what);

// Signs with one Signer (the process's sender id) and gates each kind of
// command it obeys: one CommandGate per `what` (the counter prefix and log
// name, e.g. "ROBOT_COMMAND"), made on first use.
class Authority {
 public:
  Authority(AuthorityConfig config, const Key& key, const rt::Clock& clock, CommandGate::CountFn count);

  // Throws std::logic_error when the config names no sender.
  template <class Msg>
  void sign(Msg& msg) {
    if (!signer_) throw std::logic_error("command authority: this process has no authority.sender to sign with");
    signer_->sign(msg);
  }
  template <class Msg>
  bool admit_from_controller(const std::string& what, const Msg& msg) {
    return gate(what, config_.controller_policy()).admit(msg);
  }
  template <class Msg>
  bool admit_from_operator(const std::string& what, const Msg& msg) {
    return gate(what, config_.operator_policy()).admit(msg);
  }
  // An e-stop engage is obeyed from anyone (stopping never depends on a
  // key); a clear only when an operator signed it. A message that does
  // neither changes nothing and passes.
  template <class Estop>
  bool admit_estop(const Estop& e) {
    if (e.engaged || !e.clear) return true;
    return admit_from_operator("EMERGENCY_STOP clear", e);
  }

  const AuthorityConfig& config() const { return config_; }
  const Key& key() const { return key_; }
  // "key 1a2b3c4d (sim), signs as X, obeys controller Y, operators A, B": the log line at start.
  std::string describe() const;

 private:
  CommandGate& gate(const std::string& what, const Policy& policy);

  AuthorityConfig config_;
  Key key_;
  const rt::Clock* clock_;
  CommandGate::CountFn count_;
  std::optional<Signer> signer_;
  std::map<std::string, std::unique_ptr<CommandGate>> gates_;
};

}  // namespace harvest::security
