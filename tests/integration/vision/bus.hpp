// A test's view of an LCM bus: every message on it, kept by channel and
// decoded on request, received in a thread of its own.
#pragma once

#include <atomic>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::vision::test {

class Bus {
 public:
  explicit Bus(const std::string& url) : lcm_(url) {
    lcm_.subscribeFunction(".*", &Bus::on_message, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Bus() {
    stop_ = true;
    thread_.join();
  }
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  bool good() { return lcm_.good(); }

  template <class Msg>
  void publish(const std::string& channel, const Msg& msg) {
    std::lock_guard<std::mutex> lock(publish_mutex_);
    lcm_.publish(channel, &msg);
  }

  void publish_raw(const std::string& channel, const std::vector<uint8_t>& bytes) {
    std::lock_guard<std::mutex> lock(publish_mutex_);
    lcm_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }

  // Every message received so far on `channel`, decoded (undecodable ones skipped).
  template <class Msg>
  std::vector<Msg> on(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Msg> out;
    for (const auto& [c, bytes] : records_)
      if (c == channel)
        if (auto m = rt::decode<Msg>(bytes)) out.push_back(*m);
    return out;
  }
  std::size_t count(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t n = 0;
    for (const auto& r : records_) n += r.first == channel;
    return n;
  }

 private:
  static void on_message(const lcm::ReceiveBuffer* rb, const std::string& channel, Bus* self) {
    const auto* p = static_cast<const uint8_t*>(rb->data);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->records_.emplace_back(channel, std::vector<uint8_t>(p, p + rb->data_size));
  }
  lcm::LCM lcm_;
  std::mutex mutex_, publish_mutex_;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> records_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace harvest::vision::test
