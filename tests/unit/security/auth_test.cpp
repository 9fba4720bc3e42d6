// The receiver's checks, each tripped on its own: unsigned, unknown sender,
// wrong key, altered after signing, stale, from the future, replayed.
#include "security/auth.hpp"

#include <gtest/gtest.h>

#include "twist_command.hpp"

namespace sec = harvest::security;
using harvest::rt::kMilli;
using harvest::rt::kSecond;
using harvest::rt::ManualClock;
using harvest::test::TwistCommand;

namespace {

constexpr int64_t kT0 = 1'800'000'000 * kSecond;

struct AuthTest : ::testing::Test {
  sec::Key key = sec::generate_key(sec::KeyKind::sim);
  ManualClock sender_clock{kT0};
  ManualClock receiver_clock{kT0};
  sec::Signer signer{key, "servo-controller", sender_clock};
  sec::Verifier verifier{key, sec::Policy{{"servo-controller"}, 1 * kSecond, 100 * kMilli}, receiver_clock};

  TwistCommand twist(double vx) {
    TwistCommand c;
    c.twist.linear[0] = vx;
    return c;
  }
  TwistCommand signed_twist(double vx) {
    auto c = twist(vx);
    signer.sign(c);
    return c;
  }
  int64_t refused(sec::Verdict v) const { return verifier.counts()[static_cast<int>(v)]; }
};

TEST_F(AuthTest, SignedCommandAccepted) {
  auto c = signed_twist(0.1);
  EXPECT_EQ(c.auth.sender, "servo-controller");
  EXPECT_EQ(c.auth.utime, kT0);
  EXPECT_EQ(verifier.check(c), sec::Verdict::ok);
  EXPECT_EQ(verifier.refused(), 0);
}

TEST_F(AuthTest, UnsignedRefused) {
  EXPECT_EQ(verifier.check(twist(0.1)), sec::Verdict::unsigned_command);
  // A sender name without a MAC is still unsigned.
  auto c = twist(0.1);
  c.auth.sender = "servo-controller";
  c.auth.seq = 1;
  c.auth.utime = kT0;
  EXPECT_EQ(verifier.check(c), sec::Verdict::unsigned_command);
  EXPECT_EQ(refused(sec::Verdict::unsigned_command), 2);
  EXPECT_EQ(verifier.refused(), 2);
}

TEST_F(AuthTest, WrongKeyRefused) {
  sec::Signer other{sec::generate_key(sec::KeyKind::sim), "servo-controller", sender_clock};
  auto c = twist(0.1);
  other.sign(c);
  EXPECT_EQ(verifier.check(c), sec::Verdict::bad_mac);
  EXPECT_EQ(refused(sec::Verdict::bad_mac), 1);
}

TEST_F(AuthTest, AlteredAfterSigningRefused) {
  auto c = signed_twist(0.1);
  c.twist.linear[0] = 0.3;
  EXPECT_EQ(verifier.check(c), sec::Verdict::bad_mac);
  // The auth fields are covered too: a captured command with a bumped seq
  // (to get past the replay check) or a fresh utime is not valid.
  auto d = signed_twist(0.1);
  d.auth.seq += 1000;
  EXPECT_EQ(verifier.check(d), sec::Verdict::bad_mac);
  auto e = signed_twist(0.1);
  e.auth.utime += 10 * kSecond;
  EXPECT_EQ(verifier.check(e), sec::Verdict::bad_mac);
  EXPECT_EQ(refused(sec::Verdict::bad_mac), 3);
}

TEST_F(AuthTest, UnknownSenderRefused) {
  // Holding the key is not enough: the receiver obeys the senders it is bound to.
  sec::Signer attacker{key, "attacker", sender_clock};
  auto c = twist(0.1);
  attacker.sign(c);
  EXPECT_EQ(verifier.check(c), sec::Verdict::unknown_sender);
  EXPECT_EQ(refused(sec::Verdict::unknown_sender), 1);
}

TEST_F(AuthTest, ReplayedRefused) {
  auto c = signed_twist(0.1);
  EXPECT_EQ(verifier.check(c), sec::Verdict::ok);
  EXPECT_EQ(verifier.check(c), sec::Verdict::replayed);
  // An older command of the same sender, still inside the window, is a replay too.
  auto older = signed_twist(0.2);
  auto newer = signed_twist(0.3);
  EXPECT_EQ(verifier.check(newer), sec::Verdict::ok);
  EXPECT_EQ(verifier.check(older), sec::Verdict::replayed);
  EXPECT_EQ(refused(sec::Verdict::replayed), 2);
}

TEST_F(AuthTest, StaleRefused) {
  sender_clock.set(kT0 - 3600 * kSecond);  // signed 1 h ago
  auto c = signed_twist(0.1);
  EXPECT_EQ(verifier.check(c), sec::Verdict::stale);
  // Just inside the window is accepted, just outside is not.
  sender_clock.set(kT0 - 1 * kSecond);
  EXPECT_EQ(verifier.check(signed_twist(0.1)), sec::Verdict::ok);
  sender_clock.set(kT0 + 5);
  auto d = signed_twist(0.1);
  receiver_clock.set(kT0 + 5 + 1 * kSecond + 1);
  EXPECT_EQ(verifier.check(d), sec::Verdict::stale);
  EXPECT_EQ(refused(sec::Verdict::stale), 2);
}

TEST_F(AuthTest, FromTheFutureRefused) {
  sender_clock.set(kT0 + 101 * kMilli);
  EXPECT_EQ(verifier.check(signed_twist(0.1)), sec::Verdict::future);
  sender_clock.set(kT0 + 100 * kMilli);
  EXPECT_EQ(verifier.check(signed_twist(0.1)), sec::Verdict::ok);
  EXPECT_EQ(refused(sec::Verdict::future), 1);
}

TEST_F(AuthTest, RefusedCommandDoesNotMoveTheSeq) {
  // A forged command with a huge seq must not lock the real sender out.
  sec::Signer forger{sec::generate_key(sec::KeyKind::sim), "servo-controller", sender_clock};
  auto f = twist(0.1);
  forger.sign(f);
  f.auth.seq = INT64_MAX;
  EXPECT_EQ(verifier.check(f), sec::Verdict::bad_mac);
  EXPECT_EQ(verifier.check(signed_twist(0.1)), sec::Verdict::ok);
}

TEST_F(AuthTest, SeqIsPerSender) {
  ManualClock later{kT0 + 500 * kMilli};
  sec::Signer operator_signer{key, "operator", later};
  sec::Verifier v{key, sec::Policy{{"servo-controller", "operator"}, 1 * kSecond, 1 * kSecond}, receiver_clock};
  auto a = twist(0.1);
  operator_signer.sign(a);  // seq near kT0 + 0.5 s
  EXPECT_EQ(v.check(a), sec::Verdict::ok);
  EXPECT_EQ(v.check(signed_twist(0.1)), sec::Verdict::ok);  // lower seq, other sender
}

TEST(Signer, SeqStrictlyIncreasesAndSurvivesRestart) {
  auto key = sec::generate_key(sec::KeyKind::sim);
  ManualClock clock{kT0};
  int64_t last = 0;
  {
    sec::Signer s{key, "servo-controller", clock};
    for (int i = 0; i < 5; ++i) {  // a stopped clock still gives new seqs
      int64_t seq = s.next_seq();
      EXPECT_GT(seq, last);
      last = seq;
    }
  }
  // A restarted sender starts at its clock, above what it sent a moment ago.
  clock.advance(1 * kMilli);
  sec::Signer restarted{key, "servo-controller", clock};
  EXPECT_GT(restarted.next_seq(), last);
}

TEST(Signer, NeedsASenderId) {
  ManualClock clock{kT0};
  EXPECT_THROW(sec::Signer(sec::generate_key(sec::KeyKind::sim), "", clock), std::invalid_argument);
}

TEST(Verifier, RefusesANonsensePolicy) {
  ManualClock clock{kT0};
  auto key = sec::generate_key(sec::KeyKind::sim);
  EXPECT_THROW(sec::Verifier(key, sec::Policy{{"a"}, 0, 0}, clock), std::invalid_argument);
  EXPECT_THROW(sec::Verifier(key, sec::Policy{{"a"}, kSecond, -1}, clock), std::invalid_argument);
}

TEST(Verifier, EmptyPolicyObeysNobody) {
  ManualClock clock{kT0};
  auto key = sec::generate_key(sec::KeyKind::sim);
  sec::Signer s{key, "servo-controller", clock};
  sec::Verifier v{key, sec::Policy{}, clock};
  TwistCommand c;
  s.sign(c);
  EXPECT_EQ(v.check(c), sec::Verdict::unknown_sender);
}

TEST(Mac, KnownAnswer) {
  // crypto_auth is HMAC-SHA-512 cut to 32 bytes, so a verifier in another
  // language can check it: hmac.new(b'\x0b' * 32, b'Hi There', 'sha512').hexdigest()[:64].
  sec::Key k;
  k.bytes.fill(0x0b);
  const std::string msg = "Hi There";
  auto mac = sec::compute_mac(k, reinterpret_cast<const uint8_t*>(msg.data()), msg.size());
  char hex[65] = {};
  for (int i = 0; i < 32; ++i) std::snprintf(hex + 2 * i, 3, "%02x", mac[i]);
  EXPECT_STREQ(hex, "cf768c6fd3f08f640f779ddbd9bc3842fe78a261f197da9c4a958510ac8226db");
}

}  // namespace
