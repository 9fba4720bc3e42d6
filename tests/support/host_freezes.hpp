// Times when this machine stopped running altogether, for timing tests.
//
// The test machine is a virtual machine whose host caps its CPU time: under
// load a vCPU, or both, freezes for up to ~130 ms at a time (docs/can.md "Own
// stalls"), and nothing inside the machine can prevent it. A test that times
// a process (a link's SYNC period under flood) must not blame the process for
// that. One probe thread per CPU, pinned to it and at SCHED_FIFO 95 when
// allowed, sleeps 1 ms at a time; a wake-up later than `threshold` means its
// CPU did not run for that long. Intervals are in wall-clock microseconds
// (the clock of SO_TIMESTAMP and rt::wall_time_now()).
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace harvest::testing {

// Time in [from, to) covered by any of `spans` ([start, end) each), overlaps counted once.
int64_t covered_between(std::vector<std::pair<int64_t, int64_t>> spans, int64_t from, int64_t to);

class HostFreezes {
 public:
  explicit HostFreezes(int64_t threshold_us = 10'000);
  ~HostFreezes();
  HostFreezes(const HostFreezes&) = delete;
  HostFreezes& operator=(const HostFreezes&) = delete;

  // Time in [from, to) during which any CPU was frozen [us], overlaps counted once.
  int64_t frozen_between(int64_t from, int64_t to) const;
  // The frozen intervals seen so far, [start, end) in wall-clock us, any CPU.
  std::vector<std::pair<int64_t, int64_t>> intervals() const;
  bool realtime() const { return realtime_; }  // probes ran at SCHED_FIFO (else their own gaps count too)

 private:
  void probe(int cpu);

  int64_t threshold_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> realtime_{true};
  mutable std::mutex mutex_;
  std::vector<std::pair<int64_t, int64_t>> frozen_;
  std::vector<std::thread> threads_;
};

}  // namespace harvest::testing
