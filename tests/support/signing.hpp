// Commands signed in tests as the shipped simulator configs expect them
// (docs/security.md): the sim key, the controller "servo-controller", the
// operators "operator" and "console".
#pragma once

#include <harvest/emergency_stop_t.hpp>
#include <harvest/gripper_command_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <string>
#include <type_traits>

#include "runtime/clock.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::testing {

inline constexpr const char* kController = "servo-controller";
inline constexpr const char* kOperator = "operator";

// An authority section on the sim key: signs as `sender` (empty: signs
// nothing), obeys `controller` for motion and the default operators.
security::AuthorityConfig sim_authority(const std::string& sender, const std::string& controller = kController);

// A runner's time (rt::Context::now) as an rt::Clock, to sign on it.
class RunnerClock final : public rt::Clock {
 public:
  explicit RunnerClock(const rt::Context& runner) : runner_(&runner) {}
  rt::Micros now() const override { return runner_->now(); }

 private:
  const rt::Context* runner_;
};

// Signs copies of messages as `sender` with `key` on `clock` (null: the
// wall clock, for messages sent to live processes); seq increases.
class CommandSigner {
 public:
  explicit CommandSigner(std::string sender = kController, const rt::Clock* clock = nullptr,
                         const security::Key& key = security::sim_key());
  template <class Msg>
  Msg operator()(Msg msg) {
    signer_.sign(msg);
    return msg;
  }

 private:
  rt::SystemClock wall_;
  security::Signer signer_;
};

// Wall-clock signers for messages sent to live processes (one per role,
// shared by a test's threads: call under the test's send lock).
CommandSigner& live_controller();
CommandSigner& live_operator();

// A message as the shipped sim configs expect it from its usual sender:
// ROBOT_COMMAND and GRIPPER_COMMAND signed by the controller, OPERATOR_COMMAND
// and EMERGENCY_STOP by an operator (wall clock); other types unchanged.
template <class Msg>
Msg as_sent_by_its_sender(Msg m) {
  if constexpr (std::is_same_v<Msg, robot_command_t> || std::is_same_v<Msg, gripper_command_t>)
    return live_controller()(m);
  else if constexpr (std::is_same_v<Msg, operator_command_t> || std::is_same_v<Msg, emergency_stop_t>)
    return live_operator()(m);
  else
    return m;
}

}  // namespace harvest::testing
