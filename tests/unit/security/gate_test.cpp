// The command gate: a refused command is not handed on, is counted in total
// and per reason, and is logged at most once a second with the number of
// refusals the line stands for.
#include "security/gate.hpp"

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>

#include <map>

#include "twist_command.hpp"

namespace sec = harvest::security;
using harvest::rt::kMilli;
using harvest::rt::kSecond;
using harvest::rt::ManualClock;
using harvest::test::TwistCommand;

namespace {

constexpr int64_t kT0 = 1'800'000'000 * kSecond;

struct GateTest : ::testing::Test {
  sec::Key key = sec::generate_key(sec::KeyKind::sim);
  ManualClock clock{kT0};
  std::map<std::string, int64_t> counters;
  sec::CommandGate gate{"ROBOT_COMMAND", sec::Verifier{key, sec::Policy{{"servo-controller"}}, clock}, clock,
                        [this](const std::string& c, int64_t n) { counters[c] += n; }};
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(100);
  std::shared_ptr<spdlog::logger> saved = spdlog::default_logger();

  void SetUp() override { spdlog::set_default_logger(std::make_shared<spdlog::logger>("gate", sink)); }
  void TearDown() override { spdlog::set_default_logger(saved); }
  std::vector<std::string> lines() { return sink->last_formatted(); }
};

TEST_F(GateTest, SignedPassesRefusedCountedAndLoggedOnce) {
  sec::Signer signer{key, "servo-controller", clock};
  TwistCommand ok;
  signer.sign(ok);
  EXPECT_TRUE(gate.admit(ok));
  EXPECT_TRUE(counters.empty());
  EXPECT_TRUE(lines().empty());

  TwistCommand stray;  // unsigned, as a stray publisher sends at message rate
  for (int i = 0; i < 50; ++i) {
    EXPECT_FALSE(gate.admit(stray));
    clock.advance(20 * kMilli);
  }
  EXPECT_FALSE(gate.admit(ok));  // the same signed command again: replayed
  EXPECT_EQ(counters["robot_command_refused"], 51);
  EXPECT_EQ(counters["robot_command_unsigned"], 50);
  EXPECT_EQ(counters["robot_command_replayed"], 1);
  EXPECT_EQ(gate.counter(sec::Verdict::bad_mac), "robot_command_bad_mac");
  // 51 refusals over 1 s: two lines, the second counting those not logged.
  auto l = lines();
  ASSERT_EQ(l.size(), 2u);
  EXPECT_NE(l[0].find("ROBOT_COMMAND refused (unsigned)"), std::string::npos) << l[0];
  EXPECT_NE(l[1].find("replayed"), std::string::npos) << l[1];
  EXPECT_NE(l[1].find("and 49 more refused"), std::string::npos) << l[1];
}

TEST_F(GateTest, AttackerTextIsCutShort) {
  TwistCommand c;
  sec::Signer attacker{key, std::string(1000, 'x'), clock};
  attacker.sign(c);
  EXPECT_FALSE(gate.admit(c));
  auto l = lines();
  ASSERT_EQ(l.size(), 1u);
  EXPECT_LT(l[0].size(), 300u) << l[0];
  EXPECT_EQ(counters["robot_command_unknown_sender"], 1);
}

}  // namespace
