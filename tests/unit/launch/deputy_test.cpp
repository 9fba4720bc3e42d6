// The deputy and the sheriff in memory (SimRunner, manual clock), the
// launcher behind the deputy replaced by a table the test controls: which
// orders a deputy obeys and which it refuses and counts, how much output it
// forwards, what its status says, and how the sheriff shows every host and
// follows an order to its end. Real processes over two network namespaces:
// tests/integration/tools/deputy_netns_test.cpp.
#include "launch/deputy.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <harvest/deputy_output_t.hpp>
#include <sstream>

#include "launch/sheriff.hpp"
#include "runtime/channels.hpp"
#include "runtime/sim_runner.hpp"
#include "test_support.hpp"

namespace harvest::launch {
namespace {

constexpr rt::Micros kT0 = 1'700'000'000LL * rt::kSecond;

// A launcher whose processes the test sets; a restart gives a new pid one
// second later, as a real stop and start would.
class FakeSet final : public LaunchedSet {
 public:
  std::vector<StatusRow> table;
  std::vector<std::pair<std::string, OrderAction>> orders;
  OutputTap tap;
  std::function<void(const std::string&, OrderAction)> on_order;

  std::vector<StatusRow> rows() const override { return table; }
  OrderResult order(const std::string& process, OrderAction action) override {
    orders.emplace_back(process, action);
    for (auto& r : table)
      if (r.name == process) {
        if (on_order) on_order(process, action);
        return {true, std::string(action_name(action)) + " " + process + ": done"};
      }
    return {false, std::string(action_name(action)) + " " + process + ": no such process here"};
  }
  void set_output_tap(OutputTap t) override { tap = std::move(t); }
};

StatusRow row(const std::string& name, int pid) {
  StatusRow r;
  r.name = name;
  r.group = "g";
  r.state = "running";
  r.pid = pid;
  r.heartbeat = "0.2 s";
  r.heartbeat_age_s = 0.2;
  return r;
}

DeputyOptions options(const std::string& name) {
  DeputyOptions d;
  d.name = name;
  d.host = "host-" + name;
  d.pid = 42;
  d.set_name = "set";
  d.groups = "g";
  d.authority.key = "sim";
  d.usage = [](int) { return ProcUsage{}; };
  return d;
}

harvest::launch_order_t order_for(const std::string& deputy, const std::string& process, int8_t action) {
  harvest::launch_order_t o{};
  o.deputy = deputy;
  o.process = process;
  o.action = action;
  o.source = "test";
  return o;
}

harvest::deputy_status_t last_status(const rt::SimRunner& r, const std::string& deputy) {
  harvest::deputy_status_t last;
  for (const auto& [t, s] : r.messages<harvest::deputy_status_t>(channels::kDeputyStatus))
    if (s.deputy == deputy) last = s;
  return last;
}

TEST(Deputy, ObeysOnlyOrdersAddressedToItAndSignedByAnOperator) {
  rt::SimRunner r(kT0);
  FakeSet set;
  set.table = {row("x", 100)};
  Deputy deputy(set, options("a"), security::sim_key());
  r.add(deputy);
  r.start();
  rt::ManualClock clock(kT0);
  security::Signer op(security::sim_key(), "operator", clock);

  auto o = order_for("a", "x", harvest::launch_order_t::RESTART);
  op.sign(o);
  r.inject(channels::kLaunchOrder, o);
  ASSERT_EQ(set.orders.size(), 1u);
  EXPECT_EQ(set.orders[0].second, OrderAction::kRestart);
  auto s = last_status(r, "a");  // acknowledged at once, not at the next period
  EXPECT_EQ(s.last_order_seq, o.auth.seq);
  EXPECT_TRUE(s.last_order_done);
  EXPECT_EQ(s.last_order_result, "restart x: done");
  EXPECT_EQ(s.orders_obeyed, 1);

  // Another deputy's order: not for it, not counted as refused.
  auto other = order_for("b", "x", harvest::launch_order_t::STOP);
  op.sign(other);
  r.inject(channels::kLaunchOrder, other);
  // Refused: unsigned, replayed, another key, a sender that is no operator, stale.
  r.inject(channels::kLaunchOrder, order_for("a", "x", harvest::launch_order_t::STOP));
  r.inject(channels::kLaunchOrder, o);
  auto forged = order_for("a", "x", harvest::launch_order_t::STOP);
  security::Signer(security::generate_key(security::KeyKind::robot), "operator", clock).sign(forged);
  r.inject(channels::kLaunchOrder, forged);
  auto controller = order_for("a", "x", harvest::launch_order_t::STOP);
  security::Signer(security::sim_key(), "servo-controller", clock).sign(controller);
  r.inject(channels::kLaunchOrder, controller);
  rt::ManualClock old_clock(kT0 - 5 * rt::kSecond);
  auto stale = order_for("a", "x", harvest::launch_order_t::STOP);
  security::Signer(security::sim_key(), "operator", old_clock).sign(stale);
  r.inject(channels::kLaunchOrder, stale);

  EXPECT_EQ(set.orders.size(), 1u);  // none of them reached the launcher
  s = last_status(r, "a");
  EXPECT_EQ(s.orders_refused, 5);
  EXPECT_EQ(s.orders_obeyed, 1);
  const auto& c = deputy.stats().counters;
  EXPECT_EQ(c.at("launch_order_refused"), 5);
  EXPECT_EQ(c.at("launch_order_unsigned"), 1);
  EXPECT_EQ(c.at("launch_order_replayed"), 1);
  EXPECT_EQ(c.at("launch_order_bad_mac"), 1);
  EXPECT_EQ(c.at("launch_order_unknown_sender"), 1);
  EXPECT_EQ(c.at("launch_order_stale"), 1);

  // A signed order for a process it does not have: acknowledged as not done.
  auto missing = order_for("a", "nope", harvest::launch_order_t::START);
  op.sign(missing);
  r.inject(channels::kLaunchOrder, missing);
  s = last_status(r, "a");
  EXPECT_EQ(s.last_order_seq, missing.auth.seq);
  EXPECT_FALSE(s.last_order_done);
  EXPECT_EQ(s.last_order_result, "start nope: no such process here");
}

TEST(Deputy, ForwardsOutputInBatchesAndDropsAndCountsWhatExceedsItsRate) {
  rt::SimRunner r(kT0);
  FakeSet set;
  set.table = {row("chatty", 100)};
  auto opts = options("a");
  opts.lines_per_s = 200;
  opts.burst = 400;
  Deputy deputy(set, opts, security::sim_key());
  r.add(deputy);
  r.start();
  for (int i = 0; i < 1000; ++i) set.tap("chatty", "line " + std::to_string(i) + std::string(300, 'x'));
  r.run_until(kT0 + 150 * rt::kMilli);
  auto outs = r.messages<harvest::deputy_output_t>(channels::kDeputyOutput);
  ASSERT_EQ(outs.size(), 1u);  // one batch per output period
  const auto& o = outs[0].second;
  EXPECT_EQ(o.num_lines, 400);  // the burst
  EXPECT_EQ(o.dropped, 600);
  EXPECT_EQ(o.source[0], "chatty");
  EXPECT_EQ(o.line[0].size(), 256u);  // cut
  EXPECT_EQ(o.line[0].rfind("line 0", 0), 0u);
  // One second later 200 more lines may pass, not more.
  r.run_until(kT0 + 1000 * rt::kMilli);
  for (int i = 0; i < 300; ++i) set.tap("chatty", "later " + std::to_string(i));
  r.run_until(kT0 + 1300 * rt::kMilli);
  outs = r.messages<harvest::deputy_output_t>(channels::kDeputyOutput);
  ASSERT_EQ(outs.size(), 2u);
  EXPECT_NEAR(outs[1].second.num_lines, 200, 2);
  EXPECT_NEAR(outs[1].second.dropped, 100, 2);
  r.run_until(kT0 + 2 * rt::kSecond);
  const auto s = last_status(r, "a");
  EXPECT_NEAR(s.output_dropped, 700, 2);
  ASSERT_EQ(s.num_processes, 1);
  // Its last lines are in the status whatever the rate limit dropped.
  ASSERT_EQ(s.processes[0].num_lines, 3);
  EXPECT_EQ(s.processes[0].last_lines[2], "later 299");
  EXPECT_NEAR(static_cast<double>(deputy.stats().counters.at("output_dropped")), 700, 2);
}

TEST(Deputy, StatusNamesEveryProcessWithItsCpuAndMemory) {
  rt::SimRunner r(kT0);
  FakeSet set;
  set.table = {row("busy", 100), row("idle", 200), row("down", -1)};
  set.table[2].state = "FAILED";
  set.table[2].last_exit = "139";
  auto opts = options("a");
  int64_t busy_ticks = 0;
  opts.usage = [&](int pid) {
    // busy uses half a core: half a second of ticks per second of status period.
    if (pid == 100) return ProcUsage{busy_ticks += static_cast<int64_t>(ticks_per_second() / 2), 50 << 20};
    if (pid == 200) return ProcUsage{7, 10 << 20};
    return ProcUsage{};
  };
  Deputy deputy(set, opts, security::sim_key());
  r.add(deputy);
  r.start();
  r.run_until(kT0 + 3 * rt::kSecond);
  const auto s = last_status(r, "a");
  EXPECT_EQ(s.host, "host-a");
  EXPECT_EQ(s.pid, 42);
  ASSERT_EQ(s.num_processes, 3);
  EXPECT_EQ(s.processes[0].name, "busy");
  EXPECT_NEAR(s.processes[0].cpu_percent, 50.0, 0.5);
  EXPECT_EQ(s.processes[0].rss_bytes, 50 << 20);
  EXPECT_NEAR(s.processes[1].cpu_percent, 0.0, 1e-6);
  EXPECT_EQ(s.processes[1].pid, 200);
  EXPECT_EQ(s.processes[2].state, "FAILED");
  EXPECT_EQ(s.processes[2].last_exit, 139);
  EXPECT_EQ(s.processes[2].cpu_percent, -1.0f);
  EXPECT_EQ(s.processes[2].rss_bytes, -1);
  EXPECT_NEAR(s.processes[0].heartbeat_age_s, 0.2, 1e-6);
  EXPECT_EQ(r.messages<harvest::deputy_status_t>(channels::kDeputyStatus).size(), 3u);  // 1 Hz
}

TEST(ProcUsage, ReadsCpuTicksAndResidentMemoryFromProc) {
  const ProcUsage self = read_proc_usage(getpid());
  EXPECT_GE(self.cpu_ticks, 0);
  EXPECT_GT(self.rss_bytes, 1 << 20);
  EXPECT_EQ(read_proc_usage(-5).cpu_ticks, -1);
  // A command name with spaces and parentheses: fields are counted after the last ')'.
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "77");
  std::ofstream(dir / "77" / "stat") << "77 (a) (b c) S 1 77 77 0 -1 4194560 100 0 0 0 30 12 0 0 20 0 1 0 5 1000 25 "
                                        "18446744073709551615\n";
  const ProcUsage u = read_proc_usage(77, dir.path());
  EXPECT_EQ(u.cpu_ticks, 42);
  EXPECT_EQ(u.rss_bytes, 25 * sysconf(_SC_PAGESIZE));
  EXPECT_NEAR(cpu_percent(ProcUsage{0, 0}, ProcUsage{static_cast<int64_t>(ticks_per_second()), 0}, 2.0), 50.0, 1e-9);
  EXPECT_EQ(cpu_percent(ProcUsage{}, u, 1.0), -1);
}

struct TwoHosts {
  rt::SimRunner r{kT0};
  FakeSet a_set, b_set;
  std::unique_ptr<Deputy> a, b;
  std::ostringstream out;
  Console console{out, false};
  std::unique_ptr<Sheriff> sheriff;

  explicit TwoHosts(SheriffOptions so, const security::Key& sheriff_key = security::sim_key()) {
    a_set.table = {row("x", 100), row("y", 101)};
    b_set.table = {row("z", 200)};
    b_set.on_order = [this](const std::string& p, OrderAction act) {
      // The process stops now and is running again with a new pid a second later.
      for (auto& rw : b_set.table)
        if (rw.name == p) {
          const int next = rw.pid + 1000;
          rw.state = "stopping";
          pending_pid = act == OrderAction::kStop ? -1 : next;
        }
    };
    a = std::make_unique<Deputy>(a_set, options("a"), security::sim_key());
    b = std::make_unique<Deputy>(b_set, options("b"), security::sim_key());
    sheriff = std::make_unique<Sheriff>(std::move(so), console, sheriff_key);
    r.add(*a);
    r.add(*b);
    r.add(*sheriff);
    r.start();
  }
  int pending_pid = 0;
  // Runs until `t` (or the sheriff stops), completing a pending stop/start after it was ordered.
  void run_until(rt::Micros t) {
    for (rt::Micros now = r.now(); now < t && !r.stop_requested();) {
      now += 100 * rt::kMilli;
      r.run_until(now);
      if (pending_pid != 0 && b_set.table[0].state == "stopping") {
        b_set.table[0].state = pending_pid > 0 ? "running" : "stopped";
        b_set.table[0].pid = pending_pid;
        pending_pid = 0;
      }
    }
  }
};

TEST(Sheriff, ShowsEveryHostsProcessesAndSaysWhenADeputyIsLost) {
  SheriffOptions so;
  TwoHosts h(so);
  h.run_until(kT0 + 1500 * rt::kMilli);
  auto rows = h.sheriff->rows();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].host, "a");
  EXPECT_EQ(rows[0].name, "x");
  EXPECT_EQ(rows[2].host, "b");
  EXPECT_EQ(rows[2].name, "z");
  EXPECT_EQ(rows[2].pid, 200);
  const std::string table = render_table(rows);
  EXPECT_EQ(table.rfind("HOST", 0), 0u) << table;
  EXPECT_NE(table.find("b    z"), std::string::npos) << table;
  EXPECT_NE(h.out.str().find("[sheriff] deputy b on host-b (pid 42): set set, groups g, 1 processes"),
            std::string::npos)
      << h.out.str();
  EXPECT_NE(h.out.str().find("[sheriff] b/z running (pid 200)"), std::string::npos) << h.out.str();
  // Forwarded output, named by host and process.
  h.b_set.tap("z", "hello from z");
  h.run_until(kT0 + 2 * rt::kSecond);
  EXPECT_NE(h.out.str().find("[b/z] hello from z"), std::string::npos) << h.out.str();
}

TEST(Sheriff, ADeputyWithoutStatusForThreeSecondsIsLostThenBack) {
  rt::SimRunner r(kT0);
  std::ostringstream out;
  Console console(out, false);
  Sheriff sheriff(SheriffOptions{}, console, security::sim_key());
  r.add(sheriff);
  r.start();
  harvest::deputy_status_t s{};
  s.deputy = "b";
  s.host = "host-b";
  harvest::deputy_process_t p{};
  p.name = "z";
  p.state = "running";
  p.pid = 200;
  s.processes = {p};
  s.num_processes = 1;
  r.inject(channels::kDeputyStatus, s);
  r.run_until(kT0 + 2900 * rt::kMilli);
  EXPECT_EQ(out.str().find("lost"), std::string::npos) << out.str();
  EXPECT_EQ(sheriff.rows().at(0).state, "running");
  r.run_until(kT0 + 3200 * rt::kMilli);
  EXPECT_NE(out.str().find("[sheriff] deputy b lost (no status for 3.1 s)"), std::string::npos) << out.str();
  EXPECT_EQ(sheriff.rows().at(0).state, "DEPUTY LOST");
  r.inject(channels::kDeputyStatus, s);
  EXPECT_NE(out.str().find("[sheriff] deputy b is back"), std::string::npos) << out.str();
  EXPECT_EQ(sheriff.rows().at(0).state, "running");
}

TEST(Sheriff, RestartIsSignedAcknowledgedAndDoneWhenTheProcessRunsWithANewPid) {
  SheriffOptions so;
  so.order = parse_target("b/z", OrderAction::kRestart);
  TwoHosts h(so);
  h.run_until(kT0 + 10 * rt::kSecond);
  ASSERT_TRUE(h.r.stop_requested()) << h.out.str();
  EXPECT_EQ(h.r.exit_code(), 0) << h.out.str();
  ASSERT_EQ(h.b_set.orders.size(), 1u);  // b obeyed it once; a was not addressed
  EXPECT_TRUE(h.a_set.orders.empty());
  EXPECT_NE(h.out.str().find("[sheriff] deputy b: restart z: done"), std::string::npos) << h.out.str();
  EXPECT_NE(h.out.str().find("[sheriff] restarted b/z: pid 200 -> pid 1200"), std::string::npos) << h.out.str();
  // Signed as an operator with the key given.
  const auto sent = h.r.messages<harvest::launch_order_t>(channels::kLaunchOrder);
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].second.auth.sender, "operator");
  EXPECT_EQ(+sent[0].second.action, +harvest::launch_order_t::RESTART);
}

TEST(Sheriff, AStopIsDoneWhenTheProcessHasNoPid) {
  SheriffOptions so;
  so.order = parse_target("b/z", OrderAction::kStop);
  TwoHosts h(so);
  h.run_until(kT0 + 10 * rt::kSecond);
  EXPECT_EQ(h.r.exit_code(), 0) << h.out.str();
  EXPECT_NE(h.out.str().find("[sheriff] stopped b/z (was pid 200)"), std::string::npos) << h.out.str();
}

TEST(Sheriff, AnOrderSignedWithAnotherKeyIsRefusedAndTheSheriffSaysSo) {
  SheriffOptions so;
  so.order = parse_target("b/z", OrderAction::kRestart);
  so.order_timeout = 6 * rt::kSecond;
  TwoHosts h(so, security::generate_key(security::KeyKind::robot));
  h.run_until(kT0 + 10 * rt::kSecond);
  ASSERT_TRUE(h.r.stop_requested());
  EXPECT_EQ(h.r.exit_code(), 1) << h.out.str();
  EXPECT_TRUE(h.b_set.orders.empty());
  const auto sent = h.r.messages<harvest::launch_order_t>(channels::kLaunchOrder);
  EXPECT_EQ(sent.size(), 3u);  // 2.5 s apart until the timeout, each newly signed, each refused
  EXPECT_EQ(last_status(h.r, "b").orders_refused, 3);
  EXPECT_NE(h.out.str().find("[sheriff] deputy b refused 1 order(s) (1 so far)"), std::string::npos) << h.out.str();
  EXPECT_NE(h.out.str().find("did not acknowledge the restart of b/z: it refused the order"), std::string::npos)
      << h.out.str();
  EXPECT_EQ(h.b_set.table[0].pid, 200);
}

TEST(Sheriff, AnOrderForAProcessTheDeputyDoesNotHaveNamesWhatItHas) {
  SheriffOptions so;
  so.order = parse_target("a/z", OrderAction::kStart);
  TwoHosts h(so);
  h.run_until(kT0 + 5 * rt::kSecond);
  EXPECT_EQ(h.r.exit_code(), 2) << h.out.str();
  EXPECT_NE(h.out.str().find("deputy a has no process z (it runs: x, y)"), std::string::npos) << h.out.str();
  EXPECT_TRUE(h.r.messages<harvest::launch_order_t>(channels::kLaunchOrder).empty());
  EXPECT_THROW(parse_target("a", OrderAction::kStart), std::invalid_argument);
  EXPECT_THROW(parse_target("a/b/c", OrderAction::kStart), std::invalid_argument);
  EXPECT_THROW(parse_target("/b", OrderAction::kStart), std::invalid_argument);
}

}  // namespace
}  // namespace harvest::launch
