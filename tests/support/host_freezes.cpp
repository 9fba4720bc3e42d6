#include "host_freezes.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>

namespace harvest::testing {
namespace {

int64_t now_us(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000 + t.tv_nsec / 1000;
}

}  // namespace

HostFreezes::HostFreezes(int64_t threshold_us) : threshold_(threshold_us) {
  const unsigned cpus = std::max(1u, std::thread::hardware_concurrency());
  for (unsigned c = 0; c < cpus; ++c) threads_.emplace_back([this, c] { probe(static_cast<int>(c)); });
}

HostFreezes::~HostFreezes() {
  stop_ = true;
  for (auto& t : threads_) t.join();
}

void HostFreezes::probe(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  sched_param p{};
  p.sched_priority = 95;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) != 0) realtime_ = false;
  int64_t last = now_us(CLOCK_MONOTONIC);
  while (!stop_) {
    timespec d{0, 1'000'000};
    nanosleep(&d, nullptr);
    const int64_t mono = now_us(CLOCK_MONOTONIC);
    const int64_t gap = mono - last;
    last = mono;
    if (gap <= threshold_) continue;
    const int64_t wall = now_us(CLOCK_REALTIME);
    std::lock_guard<std::mutex> lock(mutex_);
    frozen_.emplace_back(wall - gap + 1000, wall);  // less the 1 ms it meant to sleep
  }
}

std::vector<std::pair<int64_t, int64_t>> HostFreezes::intervals() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frozen_;
}

int64_t covered_between(std::vector<std::pair<int64_t, int64_t>> spans, int64_t from, int64_t to) {
  std::sort(spans.begin(), spans.end());
  int64_t total = 0, covered_to = from;
  for (auto [s, e] : spans) {
    s = std::max(s, covered_to);
    e = std::min(e, to);
    if (e <= s) continue;
    total += e - s;
    covered_to = e;
  }
  return total;
}

int64_t HostFreezes::frozen_between(int64_t from, int64_t to) const { return covered_between(intervals(), from, to); }

}  // namespace harvest::testing
