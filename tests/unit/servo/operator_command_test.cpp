// harvest-operator's verbs and how it reads the controller's reply.
#include "servo/operator_command.hpp"

#include <gtest/gtest.h>

#include "signing.hpp"

namespace harvest::servo {
namespace {

harvest_status_t status(const std::string& summary, bool estop = false) {
  harvest_status_t s{};
  s.summary = summary;
  s.estop = estop;
  return s;
}

TEST(OperatorCommand, MakesTheMessageOfEachVerb) {
  const auto start = std::get<operator_command_t>(make_operator_message("start", "me", "", 5));
  EXPECT_EQ(start.command, +operator_command_t::START);
  EXPECT_EQ(start.source, "me");
  EXPECT_EQ(start.header.utime, 5);
  const auto e = std::get<emergency_stop_t>(make_operator_message("estop", "me", "why", 5));
  EXPECT_TRUE(e.engaged);
  EXPECT_EQ(e.reason, "why");
  EXPECT_THROW(make_operator_message("go", "me", "", 5), std::invalid_argument);
}

// Every operator message is signed, each copy of a repeated one afresh (a
// receiver refuses a repeated seq as a replay).
TEST(OperatorCommand, SignsEachMessageAfresh) {
  rt::ManualClock clock(1'000'000);
  security::Signer signer(security::sim_key(), "operator", clock);
  security::Authority receiver(harvest::testing::sim_authority(""), security::sim_key(), clock,
                               [](const std::string&, int64_t) {});
  OperatorMessage a = make_operator_message("estop-clear", "me", "", clock.now());
  OperatorMessage b = a;
  sign_operator_message(a, signer);
  sign_operator_message(b, signer);
  const auto& ea = std::get<emergency_stop_t>(a);
  const auto& eb = std::get<emergency_stop_t>(b);
  EXPECT_EQ(ea.auth.sender, "operator");
  EXPECT_GT(eb.auth.seq, ea.auth.seq);
  EXPECT_TRUE(receiver.admit_estop(ea));
  EXPECT_TRUE(receiver.admit_estop(eb));
  EXPECT_FALSE(receiver.admit_estop(eb));
  OperatorMessage reset = make_operator_message("reset-fault", "me", "", clock.now());
  sign_operator_message(reset, signer);
  EXPECT_TRUE(receiver.admit_from_operator("RESET_FAULT", std::get<operator_command_t>(reset)));
}

TEST(OperatorCommand, AcknowledgementNamesThisSenderOnly) {
  const std::string me = "bob@robot (harvest-operator 42)";
  EXPECT_EQ(acknowledgement("start", me, status("SELECT | picked 0 | started by " + me)).state, AckState::kAccepted);
  EXPECT_EQ(acknowledgement("pause", me, status("APPROACH (paused) | paused by " + me)).state, AckState::kAccepted);
  EXPECT_EQ(acknowledgement("home", me, status("HOMING | homing (" + me + ")")).state, AckState::kAccepted);
  EXPECT_EQ(acknowledgement("reset-fault", me, status("IDLE | fault reset by " + me)).state, AckState::kAccepted);
  // Another sender's command, an earlier status, the wrong verb: still waiting.
  EXPECT_EQ(acknowledgement("start", me, status("SELECT | started by bob@robot (harvest-operator 41)")).state,
            AckState::kWaiting);
  EXPECT_EQ(acknowledgement("start", me, status("IDLE | picked 0")).state, AckState::kWaiting);
  EXPECT_EQ(acknowledgement("resume", me, status("APPROACH | paused by " + me)).state, AckState::kWaiting);
  // Refused: the controller's reason is the detail.
  const auto refused = acknowledgement(
      "start", me, status("ESTOP [E-STOP latched] | command refused: emergency stop latched (from " + me + ")", true));
  EXPECT_EQ(refused.state, AckState::kRefused);
  EXPECT_NE(refused.detail.find("emergency stop latched"), std::string::npos);
  EXPECT_EQ(acknowledgement("start", me, status("IDLE | command refused: busy (from someone else)")).state,
            AckState::kWaiting);
  // An emergency stop is acknowledged by the latched flag, its release by the flag cleared.
  EXPECT_EQ(acknowledgement("estop", me, status("ESTOP", true)).state, AckState::kAccepted);
  EXPECT_EQ(acknowledgement("estop", me, status("APPROACH", false)).state, AckState::kWaiting);
  EXPECT_EQ(acknowledgement("estop-clear", me, status("IDLE", false)).state, AckState::kAccepted);
  EXPECT_EQ(acknowledgement("estop-clear", me, status("ESTOP", true)).state, AckState::kWaiting);
}

}  // namespace
}  // namespace harvest::servo
