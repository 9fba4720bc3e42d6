// The authority config section and the rule that a sim key is refused on a
// real (socketcan) bus.
#include "security/authority.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace sec = harvest::security;
namespace fs = std::filesystem;
using harvest::config::Document;

namespace {

TEST(AuthorityConfig, ReadsAndDefaults) {
  auto doc = Document::load_string("authority: {key_file: /tmp/x.key, controller: servo-controller}\n");
  auto c = sec::AuthorityConfig::from_config(doc.root().child("authority"));
  doc.check_unused();
  EXPECT_EQ(c.key_file, fs::path("/tmp/x.key"));
  EXPECT_EQ(c.controller, "servo-controller");
  EXPECT_EQ(c.operators, std::vector<std::string>{"operator"});
  EXPECT_EQ(c.max_age_us, 1'000'000);
  EXPECT_EQ(c.max_ahead_us, 100'000);
  EXPECT_EQ(c.controller_policy().senders, std::vector<std::string>{"servo-controller"});
  auto doc2 = Document::load_string(
      "authority: {key_file: k, controller: c, operators: ' alice , bob,', max_age_ms: 250, max_ahead_ms: 0}\n");
  auto d = sec::AuthorityConfig::from_config(doc2.root().child("authority"));
  EXPECT_EQ(d.operators, (std::vector<std::string>{"alice", "bob"}));
  EXPECT_EQ(d.operator_policy().max_age_us, 250'000);
  EXPECT_EQ(d.operator_policy().max_ahead_us, 0);
}

TEST(AuthorityConfig, RefusesBadValues) {
  auto bad = [](const std::string& yaml) {
    auto doc = Document::load_string(yaml);
    EXPECT_THROW(sec::AuthorityConfig::from_config(doc.root().child("authority")), harvest::config::Error) << yaml;
  };
  bad("authority: {controller: c}\n");                                 // no key file
  bad("authority: {key_file: k}\n");                                   // no controller
  bad("authority: {key_file: k, controller: ''}\n");                   // empty controller
  bad("authority: {key_file: k, controller: c, operators: ' , '}\n");  // no operator
  bad("authority: {key_file: k, controller: c, max_age_ms: 0}\n");     // window closed
  bad("authority: {key_file: k, controller: c, max_ahead_ms: -1}\n");
}

TEST(AuthorityKey, SimKeyRefusedOnARealBus) {
  const fs::path dir = fs::temp_directory_path() / ("harvest-authority-test-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const auto sim = (dir / "sim.key").string(), robot = (dir / "robot.key").string();
  sec::write_key(sim, sec::generate_key(sec::KeyKind::sim));
  sec::write_key(robot, sec::generate_key(sec::KeyKind::robot));
  EXPECT_NO_THROW(sec::load_key_for_bus(sim, "udp_multicast:239.74.163.2:43113?ttl=0"));
  EXPECT_NO_THROW(sec::load_key_for_bus(sim, ""));
  EXPECT_NO_THROW(sec::load_key_for_bus(robot, "socketcan:can0"));
  try {
    sec::load_key_for_bus(sim, "socketcan:can0");
    ADD_FAILURE() << "a sim key was accepted on socketcan";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sim key"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
