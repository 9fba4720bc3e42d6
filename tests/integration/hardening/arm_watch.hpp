// What the hardening tests read from a running process set: the latest
// PROCESS_STATUS of each process, the robot state and its history, decoded
// through the guarded path (the tests' own attacks on those channels are
// dropped here as well). A thread handles LCM until destruction.
#pragma once

#include <atomic>
#include <cstdint>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::testing {

class ArmWatch {
 public:
  explicit ArmWatch(const std::string& url) : lcm_(url) {
    lcm_.subscribeFunction("PROCESS_STATUS", &ArmWatch::on_status, this);
    lcm_.subscribeFunction("ROBOT_STATE", &ArmWatch::on_state, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~ArmWatch() {
    stop_ = true;
    thread_.join();
  }
  ArmWatch(const ArmWatch&) = delete;
  ArmWatch& operator=(const ArmWatch&) = delete;

  bool good() { return lcm_.good(); }
  void publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
    std::lock_guard<std::mutex> lock(publish_mutex_);
    lcm_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }
  std::map<std::string, process_status_t> statuses() {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }
  std::optional<process_status_t> status(const std::string& instance) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = status_.find(instance);
    if (it == status_.end()) return std::nullopt;
    return it->second;
  }
  std::optional<robot_state_t> state() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (history_.empty()) return std::nullopt;
    return history_.back();
  }
  std::vector<robot_state_t> states_since(int64_t utime) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<robot_state_t> out;
    for (const auto& s : history_)
      if (s.header.utime >= utime) out.push_back(s);
    return out;
  }

 private:
  static void on_status(const lcm::ReceiveBuffer* rb, const std::string&, ArmWatch* self) {
    process_status_t s;
    if (!rt::decode_checked(rb->data, rb->data_size, s).empty()) return;
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->status_[s.instance] = s;
  }
  static void on_state(const lcm::ReceiveBuffer* rb, const std::string&, ArmWatch* self) {
    robot_state_t s;
    if (!rt::decode_checked(rb->data, rb->data_size, s).empty()) return;
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->history_.push_back(s);  // 100 Hz: a few thousand states per test
  }

  lcm::LCM lcm_;
  std::mutex mutex_, publish_mutex_;
  std::map<std::string, process_status_t> status_;
  std::vector<robot_state_t> history_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A counter summed over every node of a process (each node prefixes its name).
inline int64_t counter_sum(const process_status_t& s, const std::string& suffix) {
  int64_t n = 0;
  for (std::size_t i = 0; i < s.counter_names.size(); ++i) {
    const std::string& c = s.counter_names[i];
    if (c.size() >= suffix.size() && c.compare(c.size() - suffix.size(), suffix.size(), suffix) == 0)
      n += s.counter_values[i];
  }
  return n;
}

}  // namespace harvest::testing
