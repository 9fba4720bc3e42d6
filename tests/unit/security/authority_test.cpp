// The authority config section and the rule that a sim key is refused on a
// real (socketcan) bus.
#include "security/authority.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <map>

namespace sec = harvest::security;
namespace fs = std::filesystem;
using harvest::config::Document;

namespace {

sec::AuthorityConfig with_key(const std::string& key) {
  sec::AuthorityConfig c;
  c.key = key;
  return c;
}

TEST(AuthorityConfig, ReadsAndDefaults) {
  auto doc = Document::load_string("authority: {key: /tmp/x.key, controller: servo-controller}\n");
  auto c = sec::AuthorityConfig::from_config(doc.root().child("authority"));
  doc.check_unused();
  EXPECT_EQ(c.key, "/tmp/x.key");
  EXPECT_EQ(c.sender, "");
  EXPECT_EQ(c.controller, "servo-controller");
  EXPECT_EQ(c.operators, (std::vector<std::string>{"operator", "console"}));
  EXPECT_EQ(c.max_age_us, 1'000'000);
  EXPECT_EQ(c.max_ahead_us, 100'000);
  EXPECT_EQ(c.controller_policy().senders, std::vector<std::string>{"servo-controller"});
  auto doc2 = Document::load_string(
      "authority: {key: sim, sender: me, operators: ' alice , bob,', max_age_ms: 250, max_ahead_ms: 0}\n");
  auto d = sec::AuthorityConfig::from_config(doc2.root().child("authority"), sec::AuthorityConfig::kSender);
  EXPECT_EQ(d.key, "sim");
  EXPECT_EQ(d.sender, "me");
  EXPECT_EQ(d.operators, (std::vector<std::string>{"alice", "bob"}));
  EXPECT_EQ(d.operator_policy().max_age_us, 250'000);
  EXPECT_EQ(d.operator_policy().max_ahead_us, 0);
  EXPECT_EQ(d.load().bytes, sec::sim_key().bytes);
}

TEST(AuthorityConfig, RefusesBadValues) {
  auto bad = [](const std::string& yaml, unsigned needs = 0) {
    auto doc = Document::load_string(yaml);
    EXPECT_THROW(sec::AuthorityConfig::from_config(doc.root().child("authority"), needs), harvest::config::Error)
        << yaml;
  };
  using C = sec::AuthorityConfig;
  bad("authority: {controller: c}\n");           // no key
  bad("authority: {key: ''}\n");                 // empty key
  bad("authority: {key: k}\n", C::kController);  // a motion receiver without its controller
  bad("authority: {key: k, controller: ''}\n", C::kController);
  bad("authority: {key: k}\n", C::kSender);                    // a sender without its id
  bad("authority: {key: k, operators: ' , '}\n");              // no operator
  bad("authority: {key: k, controller: c, max_age_ms: 0}\n");  // window closed
  bad("authority: {key: k, controller: c, max_ahead_ms: -1}\n");
}

// The Authority object: signs as its sender, obeys the controller for motion
// and the operators for an e-stop clear; an engage passes unsigned.
TEST(Authority, SignsAndGatesByRole) {
  harvest::rt::ManualClock clock(1'000'000'000);
  std::map<std::string, int64_t> counters;
  auto count = [&](const std::string& c, int64_t n) { counters[c] += n; };
  auto cfg = [](const std::string& yaml) {
    auto doc = Document::load_string(yaml);
    return sec::AuthorityConfig::from_config(doc.root().child("authority"));
  };
  sec::Authority controller(cfg("authority: {key: sim, sender: servo-controller}\n"), sec::sim_key(), clock, count);
  sec::Authority op(cfg("authority: {key: sim, sender: operator}\n"), sec::sim_key(), clock, count);
  sec::Authority link(cfg("authority: {key: sim, controller: servo-controller}\n"), sec::sim_key(), clock, count);
  EXPECT_NE(link.describe().find("obeys controller 'servo-controller'"), std::string::npos) << link.describe();

  harvest::robot_command_t cmd{};
  controller.sign(cmd);
  EXPECT_TRUE(link.admit_from_controller("ROBOT_COMMAND", cmd));
  EXPECT_FALSE(link.admit_from_controller("ROBOT_COMMAND", cmd));  // the same seq again
  EXPECT_EQ(counters["robot_command_replayed"], 1);
  harvest::robot_command_t from_op{};
  op.sign(from_op);
  EXPECT_FALSE(link.admit_from_controller("ROBOT_COMMAND", from_op));
  EXPECT_EQ(counters["robot_command_unknown_sender"], 1);
  EXPECT_THROW(link.sign(cmd), std::logic_error);  // the link signs nothing

  harvest::emergency_stop_t engage{};
  engage.engaged = true;
  EXPECT_TRUE(link.admit_estop(engage));  // unsigned, from anyone
  harvest::emergency_stop_t clear{};
  clear.clear = true;
  EXPECT_FALSE(link.admit_estop(clear));
  EXPECT_EQ(counters["emergency_stop_clear_unsigned"], 1);
  controller.sign(clear);
  EXPECT_FALSE(link.admit_estop(clear));  // the controller may not clear an e-stop
  op.sign(clear);
  EXPECT_TRUE(link.admit_estop(clear));
}

TEST(AuthorityKey, SimKeyRefusedOnARealBus) {
  const fs::path dir = fs::temp_directory_path() / ("harvest-authority-test-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const auto sim = (dir / "sim.key").string(), robot = (dir / "robot.key").string();
  sec::write_key(sim, sec::generate_key(sec::KeyKind::sim));
  sec::write_key(robot, sec::generate_key(sec::KeyKind::robot));
  EXPECT_NO_THROW(with_key(sim).load("udp_multicast:239.74.163.2:43113?ttl=0"));
  EXPECT_NO_THROW(with_key(sim).load(""));
  EXPECT_NO_THROW(with_key(robot).load("socketcan:can0"));
  EXPECT_THROW(with_key("sim").load("socketcan:can0"), std::runtime_error);
  EXPECT_NO_THROW(with_key("sim").load("udp_multicast:239.74.163.2:43113?ttl=0"));
  try {
    with_key(sim).load("socketcan:can0");
    ADD_FAILURE() << "a sim key was accepted on socketcan";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sim key"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
