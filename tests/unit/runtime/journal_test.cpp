#include "runtime/journal.hpp"

#include <gtest/gtest.h>

#include <harvest/ir_range_t.hpp>
#include <set>

#include "runtime/journal_runner.hpp"
#include "runtime/log_io.hpp"
#include "runtime/timer_queue.hpp"
#include "test_nodes.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ht = harvest::testing;

namespace {

constexpr rt::Micros kT0 = 1'700'000'000'000'000;

// A timer-driven node, as the servo controller: inputs only update its state,
// its 20 ms tick publishes the newest input with the tick's now(); a one-shot
// timer 50 ms after it starts publishes once.
class LatestNode : public rt::Node {
 public:
  LatestNode() : Node("latest") {}

 protected:
  void on_attach() override {
    advertise("OUT");
    subscribe<ir_range_t>("IN", [this](const ir_range_t& m) { last_ = m.raw; });
    every(20 * rt::kMilli, [this] { out(last_); });
    after(50 * rt::kMilli, [this] { out(-1); });
  }

 private:
  void out(int32_t raw) {
    ir_range_t o{};
    o.header.utime = now();
    o.raw = raw;
    publish("OUT", o);
  }
  int32_t last_ = 0;
};

std::vector<uint8_t> ir(int32_t raw, rt::Micros t) { return rt::encode(ht::make_ir(t, raw, 0.1f)); }

}  // namespace

TEST(JournalKey, NamesAMessageByItsSizeAndFirstBytes) {
  const auto a = ir(1, kT0), b = ir(2, kT0);
  EXPECT_EQ(rt::journal_key(a.data(), a.size()), rt::journal_key(a.data(), a.size()));
  EXPECT_NE(rt::journal_key(a.data(), a.size()), rt::journal_key(b.data(), b.size()));
  std::vector<uint8_t> big(100'000, 7), big2 = big;
  big2.back() = 8;  // beyond the first 256 bytes: not read (a camera image costs nothing)
  EXPECT_EQ(rt::journal_key(big.data(), big.size()), rt::journal_key(big2.data(), big2.size()));
  big2.push_back(0);  // another size
  EXPECT_NE(rt::journal_key(big.data(), big.size()), rt::journal_key(big2.data(), big2.size()));
}

TEST(JournalWriter, ARecordIsDueEvery64EntriesOr100Ms) {
  rt::JournalWriter w("servo-controller");
  EXPECT_FALSE(w.due(kT0));
  const auto m = ir(1, kT0);
  w.message("IN", m.data(), m.size(), kT0);
  w.timer("latest#0", kT0 + 10);
  EXPECT_FALSE(w.due(kT0 + 99'999));
  EXPECT_TRUE(w.due(kT0 + 100'000));
  const node_journal_t rec = w.take(kT0 + 100'000);
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(rec.instance, "servo-controller");
  ASSERT_EQ(rec.n, 2);
  EXPECT_EQ(rec.names, (std::vector<std::string>{"IN", "latest#0"}));
  EXPECT_EQ(rec.kind, (std::vector<int8_t>{0, 1}));
  EXPECT_EQ(rec.utime, (std::vector<int64_t>{kT0, kT0 + 10}));
  EXPECT_EQ(rec.key[0], rt::journal_key(m.data(), m.size()));
  for (int i = 0; i < 64; ++i) w.timer("latest#0", kT0 + 200'000 + i);
  EXPECT_TRUE(w.due(kT0 + 200'064));
}

TEST(TimerQueue, FireNowRunsATimerOutsideItsScheduleAndEndsAOneShot) {
  rt::TimerQueue q;
  int periodic = 0, once = 0;
  const auto p = q.add(100, 10, [&] { ++periodic; });
  const auto o = q.add(50, 0, [&] { ++once; });
  EXPECT_TRUE(q.fire_now(p));
  EXPECT_TRUE(q.fire_now(o));
  EXPECT_FALSE(q.fire_now(o)) << "a one-shot timer fires once";
  EXPECT_TRUE(q.periodic(p));
  EXPECT_EQ(q.next_due(), 100) << "the periodic timer's schedule is untouched";
  EXPECT_EQ(periodic, 1);
  EXPECT_EQ(once, 1);
}

// Live, the node's socket delivered input 2 after the tick at T0+40 ms
// although the logger stamped it before; its tick ran 0.7 ms late; and the
// logger lost input 4. Driven by the journal, the replay publishes exactly
// what the live node did: the tick at its live time with input 1, not 2.
TEST(JournalRunner, ReplaysInputsAndTimersInTheLiveOrderAtTheLiveTimes) {
  ht::TempDir dir;
  const std::string in = (dir / "in.lcm").string();
  std::vector<rt::LogRecord> log;
  for (int i = 1; i <= 5; ++i)
    if (i != 4) log.push_back({kT0 + i * 15'000, "IN", ir(i, kT0 + i * 15'000)});
  rt::write_log(in, log);

  auto key = [](int i) {
    const auto m = ir(i, kT0 + i * 15'000);
    return rt::journal_key(m.data(), m.size());
  };
  rt::Journal j;
  j.entries = {
      {false, "IN", key(1), kT0 + 15'100},  // handled 0.1 ms after the logger's stamp
      {true, "latest#0", 0, kT0 + 20'700},  // the tick due at +20 ms ran at +20.7
      {true, "latest#0", 0, kT0 + 40'300},  // before input 2 reached this socket ...
      {false, "IN", key(2), kT0 + 40'350},  // ... though the logger had it at +30 ms
      {true, "latest#1", 0, kT0 + 50'200},  // the one-shot
      {false, "IN", key(3), kT0 + 55'020},
      {false, "IN", key(4), kT0 + 60'010},  // lost by the logger
      {true, "latest#0", 0, kT0 + 60'500},
      {true, "heartbeat#0", 0, kT0 + 61'000},  // the process's heartbeat: not replayed
  };
  LatestNode node;
  rt::JournalRunner runner("", kT0, j);
  runner.add(node);
  rt::replay_journals(in, {&runner});
  const auto& r = runner.result();
  EXPECT_EQ(r.messages, 3);
  EXPECT_EQ(r.timers, 4);
  EXPECT_EQ(r.missing_inputs, 1);
  EXPECT_EQ(r.other_timers, 1);
  ASSERT_EQ(r.missing.size(), 1u);
  EXPECT_NE(r.missing[0].find("IN at " + std::to_string(kT0 + 60'010)), std::string::npos) << r.missing[0];

  std::vector<std::pair<int64_t, int32_t>> got;
  for (const auto& rec : runner.published()) {
    ASSERT_EQ(rec.channel, "OUT");
    const auto decoded = rt::decode<ir_range_t>(rec.data);
    ASSERT_TRUE(decoded);
    const ir_range_t& m = *decoded;
    EXPECT_EQ(rec.timestamp, m.header.utime);
    got.emplace_back(m.header.utime - kT0, m.raw);
  }
  const std::vector<std::pair<int64_t, int32_t>> want = {{20'700, 1}, {40'300, 1}, {50'200, -1}, {60'500, 3}};
  EXPECT_EQ(got, want);
}

// All journalled processes go through the log in one pass: two processes
// handling the same recorded inputs in their own orders and moments each get
// every one of them, and publish what each publishes replayed alone.
TEST(JournalRunner, ProcessesReplayedInOnePassEachGetWhatTheyGetAlone) {
  ht::TempDir dir;
  const std::string in = (dir / "in.lcm").string();
  std::vector<rt::LogRecord> log;
  for (int i = 1; i <= 40; ++i) log.push_back({kT0 + i * 15'000, "IN", ir(i, kT0 + i * 15'000)});
  rt::write_log(in, log);
  auto key = [](int i) {
    const auto m = ir(i, kT0 + i * 15'000);
    return rt::journal_key(m.data(), m.size());
  };
  rt::Journal a, b;  // a handles every input 0.2 ms after the logger; b later, with its ticks between them
  for (int i = 1; i <= 40; ++i) {
    a.entries.push_back({false, "IN", key(i), kT0 + i * 15'000 + 200});
    if (i % 2 == 0) b.entries.push_back({true, "latest#0", 0, kT0 + i * 15'000 + 1'000});
    b.entries.push_back({false, "IN", key(i), kT0 + i * 15'000 + 3'000});
    if (i % 3 == 0) a.entries.push_back({true, "latest#0", 0, kT0 + i * 15'000 + 500});
  }
  auto alone = [&](const rt::Journal& j) {
    LatestNode node;
    rt::JournalRunner r("", kT0, j);
    r.add(node);
    rt::replay_journals(in, {&r});
    EXPECT_EQ(r.result().messages, 40);
    return r.published();
  };
  LatestNode na, nb;
  rt::JournalRunner ra("", kT0, a), rb("", kT0 + 10'000, b);
  ra.add(na);
  rb.add(nb);
  rt::replay_journals(in, {&ra, &rb});
  EXPECT_EQ(ra.result().messages, 40);
  EXPECT_EQ(rb.result().messages, 40);
  EXPECT_EQ(rb.result().missing_inputs, 0);
  EXPECT_EQ(ra.published(), alone(a));
  ASSERT_FALSE(rb.published().empty());
  rt::JournalRunner rb_alone("", kT0 + 10'000, b);
  LatestNode nb_alone;
  rb_alone.add(nb_alone);
  rt::replay_journals(in, {&rb_alone});
  EXPECT_EQ(rb.published(), rb_alone.published());
}

// The logger loses a record now and then (a UDP datagram under load): each
// record repeats the one before, so one lost record costs nothing; two in a
// row lose the first of them.
TEST(Journal, ARecordTheLoggerLostIsRecoveredFromTheNext) {
  ht::TempDir dir;
  rt::JournalWriter w("detector-fixed");
  std::vector<node_journal_t> records;
  for (int r = 0; r < 5; ++r) {
    for (int i = 0; i < 3; ++i) w.timer("t#0", kT0 + r * 1000 + i);
    records.push_back(w.take(kT0 + r * 1000 + 999));
  }
  auto entries_of = [&](std::set<int> dropped) {
    std::vector<rt::LogRecord> log;
    for (int r = 0; r < 5; ++r)
      if (!dropped.count(r)) log.push_back({kT0 + r * 1000 + 999, "JOURNAL", rt::encode(records[r])});
    const std::string path = (dir / ("j" + std::to_string(dropped.size()) + ".lcm")).string();
    rt::write_log(path, log);
    return rt::read_journals(path, "").at("detector-fixed");
  };
  const rt::Journal all = entries_of({});
  ASSERT_EQ(all.entries.size(), 15u);
  for (int k = 0; k < 15; ++k) EXPECT_EQ(all.entries[k].utime, kT0 + (k / 3) * 1000 + k % 3);
  const rt::Journal one = entries_of({2});
  EXPECT_EQ(one.recovered_records, 1);
  EXPECT_EQ(one.missing_records, 0);
  ASSERT_EQ(one.entries.size(), 15u);
  for (std::size_t k = 0; k < 15; ++k) EXPECT_EQ(one.entries[k].utime, all.entries[k].utime);
  const rt::Journal two = entries_of({1, 2});
  EXPECT_EQ(two.recovered_records, 1);
  EXPECT_EQ(two.missing_records, 1);
  EXPECT_EQ(two.entries.size(), 12u) << "record 1's three entries are gone";
}
