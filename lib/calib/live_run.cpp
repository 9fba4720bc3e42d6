#include "calib/live_run.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include "runtime/live_runner.hpp"

namespace harvest::calib {
namespace {
std::atomic<rt::LiveRunner*> g_live{nullptr};
extern "C" void on_signal(int) { stop_live(); }
}  // namespace

void stop_live() {
  if (auto* r = g_live.load()) r->request_stop(0);
}

int run_live(rt::Node& node, const std::string& lcm_url, const std::string& prefix, double timeout_s) {
  rt::LiveOptions lo;
  lo.lcm_url = lcm_url;
  lo.prefix = prefix;
  rt::LiveRunner runner(lo);
  runner.add(node);
  g_live = &runner;
  auto* old_int = std::signal(SIGINT, on_signal);
  auto* old_term = std::signal(SIGTERM, on_signal);
  std::atomic<bool> done{false};
  std::thread timer;
  if (timeout_s > 0)
    timer = std::thread([&] {
      const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
      while (!done && std::chrono::steady_clock::now() < end)
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (!done) runner.request_stop(0);
    });
  const int rc = runner.run();
  done = true;
  if (timer.joinable()) timer.join();
  std::signal(SIGINT, old_int);
  std::signal(SIGTERM, old_term);
  g_live = nullptr;
  return rc;
}

}  // namespace harvest::calib
