// A typed LCM subscription for tools that drive an lcm::LCM themselves
// (harvest-operator, the demo driver) instead of running nodes. lcm-cpp's own
// typed subscribe() runs the generated decoder on the raw bytes, and one
// datagram with a zero string length throws out of LCM::handle() and ends
// the tool; this one decodes through decode_checked like Node::subscribe,
// drops and counts malformed messages and logs them at most once a second.
#pragma once

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "runtime/log_limiter.hpp"
#include "runtime/wire_check.hpp"

namespace harvest::rt {

template <class Msg>
class CheckedSubscription {
 public:
  CheckedSubscription(lcm::LCM& lcm, const std::string& channel, std::function<void(const Msg&)> handler)
      : lcm_(lcm), handler_(std::move(handler)) {
    sub_ = lcm_.subscribe(channel, &CheckedSubscription::on_raw, this);
  }
  ~CheckedSubscription() { lcm_.unsubscribe(sub_); }
  CheckedSubscription(const CheckedSubscription&) = delete;
  CheckedSubscription& operator=(const CheckedSubscription&) = delete;

  int64_t malformed() const { return malformed_; }

 private:
  void on_raw(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    Msg m;
    const std::string why = decode_checked(rbuf->data, rbuf->data_size, m);
    if (why.empty()) {
      handler_(m);
      return;
    }
    ++malformed_;
    const Micros now =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count();
    int64_t suppressed = 0;
    Micros since = 0;
    if (log_.admit(now, suppressed, since))
      spdlog::warn("dropped malformed {} on {} ({} bytes): {}; {} so far", Msg::getTypeName(), channel, rbuf->data_size,
                   why, malformed_);
  }

  lcm::LCM& lcm_;
  std::function<void(const Msg&)> handler_;
  lcm::Subscription* sub_ = nullptr;
  int64_t malformed_ = 0;
  LogLimiter log_;
};

}  // namespace harvest::rt
