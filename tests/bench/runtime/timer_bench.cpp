// How late the live runner fires a node's timer (the servo controller's 50 Hz
// tick, a camera's frame timer): a node on a LiveRunner over LCM (ttl=0, a
// port of its own) with a 2 ms timer records now() - due for 250 ticks. The
// counters are the median, p99 and maximum lateness in microseconds; the
// iteration time is the 0.5 s run. docs/performance.md quotes one run.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <vector>

#include "runtime/live_runner.hpp"
#include "runtime/node.hpp"
#include "test_support.hpp"

namespace {

using namespace harvest;

class Ticker final : public rt::Node {
 public:
  explicit Ticker(int ticks) : rt::Node("ticker"), ticks_(ticks) {}
  std::vector<rt::Micros> lateness;

 protected:
  void on_attach() override {
    const rt::Micros period = 2 * rt::kMilli;
    const rt::Micros first = now() + period;
    ctx().add_timer(first, period, [this, first, period] {
      const rt::Micros due = first + static_cast<rt::Micros>(lateness.size()) * period;
      lateness.push_back(now() - due);
      if (static_cast<int>(lateness.size()) == ticks_) ctx().request_stop(0);
    });
  }

 private:
  int ticks_;
};

void BM_LiveRunnerTimerLateness(benchmark::State& state) {
  std::vector<rt::Micros> all;
  for (auto _ : state) {
    rt::LiveRunner runner({harvest::testing::unique_lcm_url(), "", rt::kSecond});
    Ticker ticker(250);
    runner.add(ticker);
    runner.run();
    all.insert(all.end(), ticker.lateness.begin(), ticker.lateness.end());
  }
  std::sort(all.begin(), all.end());
  auto rank = [&](double p) {
    return static_cast<double>(all[std::min(all.size() - 1, static_cast<std::size_t>(p * all.size()))]);
  };
  state.counters["late_p50_us"] = rank(0.50);
  state.counters["late_p99_us"] = rank(0.99);
  state.counters["late_max_us"] = static_cast<double>(all.back());
}
BENCHMARK(BM_LiveRunnerTimerLateness)->Unit(benchmark::kMillisecond)->Iterations(4);

}  // namespace

BENCHMARK_MAIN();
