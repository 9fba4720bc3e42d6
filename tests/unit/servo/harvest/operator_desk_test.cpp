#include "servo/harvest/operator_desk.hpp"

#include <gtest/gtest.h>

namespace harvest::servo {
namespace {

using Do = OperatorDesk::Order::Do;
constexpr rt::Micros kT = 5'000'000;

operator_command_t command(int8_t c, const std::string& source = "field-ui") {
  operator_command_t m{};
  m.command = c;
  m.source = source;
  return m;
}

emergency_stop_t estop(bool engaged, bool clear, const std::string& reason = "") {
  emergency_stop_t m{};
  m.engaged = engaged;
  m.clear = clear;
  m.source = "pendant";
  m.reason = reason;
  return m;
}

TEST(OperatorDesk, ACommandTheStateDoesNotAllowIsRefusedNamingItsSender) {
  OperatorDesk d;
  OperatorDesk::Order o = d.command(command(operator_command_t::START), State::kApproach, true, kT);
  EXPECT_EQ(o.what, Do::kRefused);
  EXPECT_EQ(o.note, "command refused: already running (from field-ui)");
  o = d.command(command(operator_command_t::START, ""), State::kIdle, false, kT);
  EXPECT_EQ(o.note, "command refused: no robot state (from operator)");
  o = d.command(command(operator_command_t::START), State::kIdle, true, kT);
  EXPECT_EQ(o.what, Do::kStart);
  EXPECT_EQ(o.note, "started by field-ui");
  EXPECT_EQ(d.command(command(operator_command_t::RESET_FAULT), State::kFault, true, kT).what, Do::kResetFault);
}

// Paused at 5 s, resumed at 7.5 s: the timeouts stood still 2.5 s. ABORT and HOME end a pause too.
TEST(OperatorDesk, ThePauseSaysHowLongTheTimeoutsStoodStill) {
  OperatorDesk d;
  EXPECT_EQ(d.command(command(operator_command_t::RESUME), State::kApproach, true, kT).note,
            "command refused: not paused (from field-ui)");
  OperatorDesk::Order o = d.command(command(operator_command_t::PAUSE), State::kApproach, true, kT);
  EXPECT_EQ(o.what, Do::kPause);
  EXPECT_EQ(o.note, "paused by field-ui");
  EXPECT_TRUE(d.paused());
  EXPECT_EQ(d.command(command(operator_command_t::PAUSE), State::kApproach, true, kT).what, Do::kRefused);
  o = d.command(command(operator_command_t::RESUME), State::kApproach, true, kT + 2'500'000);
  EXPECT_EQ(o.what, Do::kResume);
  EXPECT_EQ(o.paused_for, 2'500'000);
  EXPECT_EQ(o.note, "resumed by field-ui");
  EXPECT_FALSE(d.paused());
  for (const int8_t ends : {operator_command_t::ABORT, operator_command_t::HOME}) {
    d.command(command(operator_command_t::PAUSE), State::kApproach, true, kT);
    ASSERT_TRUE(d.paused());
    o = d.command(command(ends), State::kApproach, true, kT);
    EXPECT_EQ(o.what, ends == operator_command_t::ABORT ? Do::kAbort : Do::kHome);
    EXPECT_EQ(o.note, ends == operator_command_t::ABORT ? "aborted by field-ui" : "homing (field-ui)");
    EXPECT_FALSE(d.paused());
  }
  d.command(command(operator_command_t::PAUSE), State::kApproach, true, kT);
  d.unpause();  // a fault
  EXPECT_FALSE(d.paused());
}

// Engaged: latched (and any pause over) until its own clear; START and HOME are refused meanwhile, ABORT is not.
TEST(OperatorDesk, TheEmergencyStopLatchesUntilItsOwnClear) {
  OperatorDesk d;
  EXPECT_EQ(d.on_estop(estop(false, true)).what, OperatorDesk::Stop::Do::kNothing);  // nothing latched
  d.command(command(operator_command_t::PAUSE), State::kApproach, true, kT);
  OperatorDesk::Stop s = d.on_estop(estop(true, false, "button"));
  EXPECT_EQ(s.what, OperatorDesk::Stop::Do::kEngage);
  EXPECT_EQ(s.note, "EMERGENCY STOP from pendant: button");
  EXPECT_TRUE(d.estop());
  EXPECT_FALSE(d.paused());
  EXPECT_EQ(d.on_estop(estop(true, false)).what, OperatorDesk::Stop::Do::kHold);
  EXPECT_EQ(d.on_estop(estop(false, false)).what, OperatorDesk::Stop::Do::kNothing);  // neither: still latched
  EXPECT_TRUE(d.estop());
  EXPECT_EQ(d.command(command(operator_command_t::HOME), State::kEstop, true, kT).note,
            "command refused: emergency stop latched (from field-ui)");
  EXPECT_EQ(d.command(command(operator_command_t::ABORT), State::kEstop, true, kT).what, Do::kAbort);
  s = d.on_estop(estop(false, true));
  EXPECT_EQ(s.what, OperatorDesk::Stop::Do::kClear);
  EXPECT_EQ(s.note, "emergency stop cleared by pendant");
  EXPECT_FALSE(d.estop());
  EXPECT_EQ(d.on_estop(estop(true, false)).note, "EMERGENCY STOP from pendant");
}

}  // namespace
}  // namespace harvest::servo
