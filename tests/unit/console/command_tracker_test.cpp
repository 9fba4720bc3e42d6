#include "console/command_tracker.hpp"

#include <gtest/gtest.h>

namespace harvest::console {
namespace {

harvest_status_t status(const std::string& summary, bool estop = false) {
  harvest_status_t s{};
  s.summary = summary;
  s.estop = estop;
  return s;
}

TEST(ConsoleRequest, ButtonsMapToOperatorVerbs) {
  for (const char* verb : {"start", "pause", "resume", "abort", "home", "reset-fault", "estop", "estop-clear"})
    EXPECT_EQ(verb_of_request(std::string("{\"command\":\"") + verb + "\"}"), verb);
}

TEST(ConsoleRequest, BadRequestsRefusedSayingWhy) {
  const auto why = [](const std::string& text) {
    try {
      verb_of_request(text);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(why("start"), "request is not JSON");
  EXPECT_EQ(why("{\"verb\":\"start\"}"), "request has no \"command\" string");
  EXPECT_EQ(why("{\"command\":3}"), "request has no \"command\" string");
  EXPECT_EQ(why("[\"start\"]"), "request has no \"command\" string");
  EXPECT_EQ(why("{\"command\":\"launch\"}"), "unknown command \"launch\"");
}

TEST(CommandTracker, NothingBeforeTheFirstCommand) {
  CommandTracker t("op@host (harvest-console 1)");
  EXPECT_TRUE(t.to_json(0).is_null());
  t.on_status(status("started by op@host (harvest-console 1)"), 10);
  EXPECT_TRUE(t.to_json(10).is_null());
}

TEST(CommandTracker, StartAcceptedByTheControllersReplyNamingThisConsole) {
  CommandTracker t("op@host (harvest-console 1)");
  const auto msg = t.command("start", 1'000'000);
  const auto& cmd = std::get<operator_command_t>(msg);
  EXPECT_EQ(cmd.command, +operator_command_t::START);
  EXPECT_EQ(cmd.source, "op@host (harvest-console 1)");
  EXPECT_EQ(cmd.header.utime, 1'000'000);
  EXPECT_EQ(t.to_json(1'100'000)["state"], "waiting");
  // Another sender's start is not this console's acknowledgement.
  t.on_status(status("SELECT: started by op@host (harvest-operator 7)"), 1'200'000);
  EXPECT_EQ(t.to_json(1'200'000)["state"], "waiting");
  t.on_status(status("SELECT: started by op@host (harvest-console 1)"), 1'300'000);
  const auto j = t.to_json(1'400'000);
  EXPECT_EQ(j["verb"], "start");
  EXPECT_EQ(j["state"], "accepted");
  EXPECT_EQ(j["detail"], "SELECT: started by op@host (harvest-console 1)");
}

TEST(CommandTracker, RefusalShownWithTheControllersReason) {
  CommandTracker t("c");
  t.command("resume", 0);
  t.on_status(status("IDLE: command refused: not paused (from c)"), 1000);
  EXPECT_EQ(t.to_json(2000)["state"], "refused");
  EXPECT_EQ(t.to_json(2000)["detail"], "IDLE: command refused: not paused (from c)");
}

TEST(CommandTracker, NoReplyAfterTheTimeoutAndALateReplyIgnored) {
  CommandTracker t("c", 3'000'000);
  t.command("pause", 0);
  EXPECT_EQ(t.to_json(2'999'999)["state"], "waiting");
  EXPECT_EQ(t.to_json(3'000'001)["state"], "no reply");
  t.on_status(status("paused by c"), 3'500'000);
  EXPECT_EQ(t.to_json(3'600'000)["state"], "no reply");
}

TEST(CommandTracker, EstopIsAnEmergencyStopAcknowledgedByTheLatchedFlag) {
  CommandTracker t("c");
  const auto msg = t.command("estop", 0);
  const auto& e = std::get<emergency_stop_t>(msg);
  EXPECT_TRUE(e.engaged);
  EXPECT_FALSE(e.clear);
  EXPECT_EQ(e.reason, "operator console");
  t.on_status(status("MOVE", false), 10);
  EXPECT_EQ(t.to_json(20)["state"], "waiting");
  t.on_status(status("ESTOP: emergency stop", true), 30);
  EXPECT_EQ(t.to_json(40)["state"], "accepted");
  // A new command replaces the shown one.
  t.command("estop-clear", 50);
  EXPECT_EQ(t.to_json(60)["verb"], "estop-clear");
  EXPECT_EQ(t.to_json(60)["state"], "waiting");
  t.on_status(status("IDLE", false), 70);
  EXPECT_EQ(t.to_json(80)["state"], "accepted");
}

TEST(CommandTracker, InvalidRequestStaysShownUntilTheNextCommand) {
  CommandTracker t("c");
  t.command("reset-fault", 0);
  t.on_status(status("IDLE: command refused: no fault to reset (from c)"), 10);
  t.invalid_request("unknown command \"launch\"", 20);
  EXPECT_EQ(t.to_json(30)["state"], "invalid");
  EXPECT_EQ(t.to_json(30)["detail"], "console: unknown command \"launch\"; nothing sent");
  t.on_status(status("IDLE: command refused: no fault to reset (from c)"), 40);
  EXPECT_EQ(t.to_json(10'000'000)["state"], "invalid");  // never turns into "no reply"
  t.command("start", 50);
  EXPECT_EQ(t.to_json(60)["state"], "waiting");
}

TEST(CommandTracker, SendFailureShown) {
  CommandTracker t("c");
  t.command("home", 0);
  t.send_failed(1);
  EXPECT_EQ(t.to_json(2)["state"], "send failed");
  t.on_status(status("homing (c)"), 3);  // nothing was sent: a reply cannot be ours
  EXPECT_EQ(t.to_json(4)["state"], "send failed");
}

}  // namespace
}  // namespace harvest::console
