// The servo controller node: wires HarvestMachine to the bus. Inputs are
// handed to the machine one at a time; a timer at tick_period_s runs the
// control step; HARVEST_STATUS goes out on every change and every
// status_period_s, with a one-line summary logged on each change.
#pragma once

#include <string>

#include "runtime/node.hpp"
#include "security/authority.hpp"
#include "servo/harvest_machine.hpp"

namespace harvest::servo {

class ServoControllerNode final : public rt::Node {
 public:
  // `authority`: the key it signs ROBOT_COMMAND and GRIPPER_COMMAND with and
  // its sender id; whom it obeys for OPERATOR_COMMAND and an e-stop clear.
  ServoControllerNode(ServoConfig config, security::AuthorityConfig authority, std::string name = "servo-controller");

  const HarvestMachine& machine() const { return machine_; }

 protected:
  void on_attach() override;

 private:
  void emit(MachineOutput out);
  void publish_status();

  ServoConfig cfg_;
  security::Authority authority_;
  HarvestMachine machine_;
  std::string last_summary_;
  rt::Micros tbz_error_published_ = 0;
  void publish_tbz_error();     // approach_mode tbz: the errors of a new TBZ step on TBZ_ERROR
  rt::LogLimiter invalid_log_;  // invalid inputs are logged at most once a second
};

}  // namespace harvest::servo
