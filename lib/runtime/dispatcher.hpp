// The part of a runner that is the same live and in replay: subscriptions,
// timers and the clock the nodes see.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "runtime/log_limiter.hpp"
#include "runtime/node.hpp"

namespace harvest::rt {

class Dispatcher : public Context {
 public:
  explicit Dispatcher(std::string prefix) : prefix_(std::move(prefix)) {}

  // Nodes are owned by the caller and attached when the runner starts.
  void add(Node& node) { nodes_.push_back(&node); }
  const std::vector<Node*>& nodes() const { return nodes_; }

  // Context
  void subscribe_bytes(const std::string& channel, RawHandler handler) override;
  void advertise(const std::string& channel) override { advertised_.insert(channel); }
  TimerId add_timer(Micros first_due, Micros period, std::function<void()> callback,
                    const std::string& owner = {}) override;
  void cancel_timer(TimerId id) override;
  // "owner#k" (see Context::add_timer), "#id" for a timer without an owner.
  std::string timer_label(TimerId id) const;
  // The live timer with this label, if any.
  std::optional<TimerId> timer_by_label(const std::string& label) const;

  const std::string& prefix() const { return prefix_; }
  std::string full_channel(const std::string& channel) const { return prefix_ + channel; }
  // Logical channel for a bus channel, or empty if it lacks our prefix.
  std::string logical_channel(const std::string& full) const;
  bool is_subscribed(const std::string& channel) const { return handlers_.count(channel) != 0; }
  const std::set<std::string>& advertised() const { return advertised_; }

 protected:
  // Called the first time any node subscribes to a channel.
  virtual void on_first_subscription(const std::string& /*channel*/) {}
  void attach_all();
  // Deliver one encoded message to every handler of channel.
  void deliver(const std::string& channel, const void* data, std::size_t size, Micros receive_time);
  // A one-shot timer that fired, or a cancelled one: its label goes.
  void forget_timer(TimerId id);

  TimerQueue timers_;

 private:
  std::string prefix_;
  std::vector<Node*> nodes_;
  std::map<std::string, std::vector<RawHandler>> handlers_;
  std::set<std::string> advertised_;
  std::map<TimerId, std::string> timer_labels_;
  std::map<std::string, TimerId> timer_ids_;
  std::map<std::string, int> timers_per_owner_;
  LogLimiter raw_handler_log_;
};

}  // namespace harvest::rt
